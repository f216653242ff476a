#pragma once
// The colour map of the maps' pictures: perceptually uniform by construction. Along t in [0, 1]
// CIELAB lightness rises linearly from 20 to 95 while the hue turns at a constant chroma of 30
// from 330° (purple) through blue and green to 100° (yellow), so that equal steps of t are equal
// colour differences (ΔE*ab) everywhere, and the map reads dark to light in grey as well. Every
// colour lies inside the sRGB gamut: none is clipped (docs/maps.md, "Pictures").

#include <array>

namespace skinspec::maps {

struct LabColour {
  double l, a, b;
};

// The map's colour at t (clamped to [0, 1]) in CIELAB, and in linear sRGB.
LabColour map_lab(double t);
std::array<double, 3> map_linear_srgb(double t);

// CIELAB (D65 white) to linear sRGB, not clipped.
std::array<double, 3> lab_to_linear_srgb(const LabColour& lab);

// Neutral colours outside the map's chroma: a pixel whose value the spectrum does not
// determine, and one that is not skin (or could not be fitted).
inline constexpr LabColour kNotDeterminedLab{80, 0, 0};
inline constexpr LabColour kMaskedLab{8, 0, 0};

}  // namespace skinspec::maps
