#include "skinspec/render/torrance_sparrow.hpp"

#include <algorithm>
#include <numbers>

namespace skinspec::render {

double facet_distribution(double phi, double roughness) {
  return std::exp(-std::numbers::ln2 * phi * phi / (roughness * roughness));
}

double fresnel(double c, double index) {
  const double g = std::sqrt(index * index + c * c - 1.0);
  const double ratio = (g - c) / (g + c);
  const double inner = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
  return 0.5 * ratio * ratio * (1.0 + inner * inner);
}

double geometric_attenuation(double cos_phi, double cos_theta_r, double cos_theta_i, double cos_theta_q) {
  return std::min({1.0, 2.0 * cos_phi * cos_theta_r / cos_theta_q, 2.0 * cos_phi * cos_theta_i / cos_theta_q});
}

Shading torrance_sparrow(const Vec3& n, const Vec3& to_light, const Vec3& to_viewer, const SurfaceParams& surface) {
  const double cos_i = dot(n, to_light), cos_r = dot(n, to_viewer);
  if (cos_i <= 0 || cos_r <= 0) return {};
  const Vec3 q = normalized(to_light + to_viewer);
  const double cos_phi = std::clamp(dot(n, q), -1.0, 1.0);
  const double cos_q = std::clamp(dot(to_light, q), 1e-9, 1.0);
  const double d = facet_distribution(std::acos(cos_phi), surface.roughness);
  const double specular =
      surface.beta * d * fresnel(cos_q, surface.index) * geometric_attenuation(cos_phi, cos_r, cos_i, cos_q) / cos_r;
  return {surface.alpha * cos_i, specular};
}

}  // namespace skinspec::render
