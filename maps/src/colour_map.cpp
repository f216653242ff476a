#include "skinspec/maps/colour_map.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "skinspec/spectral/colour.hpp"

namespace skinspec::maps {

namespace {

constexpr double kLightnessFrom = 20, kLightnessTo = 95, kChroma = 30, kHueFrom = 330, kHueTo = 100;
// CIE D65, Y = 1: the white CIELAB is relative to.
constexpr Xyz kD65White{0.95047, 1.0, 1.08883};

// The inverse of CIELAB's cube-root function f.
double f_inverse(double t) {
  constexpr double delta = 6.0 / 29.0;
  return t > delta ? t * t * t : 3 * delta * delta * (t - 4.0 / 29.0);
}

}  // namespace

LabColour map_lab(double t) {
  t = std::clamp(t, 0.0, 1.0);
  const double hue = (kHueFrom + (kHueTo - kHueFrom) * t) * std::numbers::pi / 180;
  return {kLightnessFrom + (kLightnessTo - kLightnessFrom) * t, kChroma * std::cos(hue), kChroma * std::sin(hue)};
}

std::array<double, 3> lab_to_linear_srgb(const LabColour& lab) {
  const double fy = (lab.l + 16) / 116, fx = fy + lab.a / 500, fz = fy - lab.b / 200;
  return xyz_to_linear_srgb({kD65White.x * f_inverse(fx), kD65White.y * f_inverse(fy), kD65White.z * f_inverse(fz)});
}

std::array<double, 3> map_linear_srgb(double t) { return lab_to_linear_srgb(map_lab(t)); }

}  // namespace skinspec::maps
