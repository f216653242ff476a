#pragma once
// Linear resampling, one point at a time: Spectrum::resampled keeps the values, the tristimulus
// sums add them up as they come, and a weighting carried onto a grid of samples gathers each
// point's weight onto the two samples it is interpolated from. All three place the points alike.

#include <cstddef>
#include <span>

namespace skinspec::detail {

// Calls place(i, lower, t, past_end) for each point of `grid_nm` in turn: it lies between samples
// `lower` and lower + 1 (`wavelength_nm` increasing, at least two), t of the way, or it is at or
// past an end (past_end), where the value is held constant at sample `lower` (t = 0).
template <typename Place>
void place_onto(std::span<const double> wavelength_nm, std::span<const double> grid_nm, Place place) {
  // One sweep along both grids when the target is ordered (the usual case), instead of a
  // search per point.
  std::size_t upper = 1;
  for (std::size_t i = 0; i < grid_nm.size(); ++i) {
    const double w = grid_nm[i];
    if (i > 0 && w < grid_nm[i - 1]) upper = 1;
    if (w <= wavelength_nm.front()) {
      place(i, std::size_t{0}, 0.0, true);
      continue;
    }
    if (w >= wavelength_nm.back()) {
      place(i, wavelength_nm.size() - 1, 0.0, true);
      continue;
    }
    while (wavelength_nm[upper] < w) ++upper;
    const double t = (w - wavelength_nm[upper - 1]) / (wavelength_nm[upper] - wavelength_nm[upper - 1]);
    place(i, upper - 1, t, false);
  }
}

// Calls take(i, value) for each point of `grid_nm` in turn, with the samples interpolated
// linearly there and held constant past their ends.
template <typename Take>
void resample_onto(std::span<const double> wavelength_nm, std::span<const double> values,
                   std::span<const double> grid_nm, Take take) {
  place_onto(wavelength_nm, grid_nm, [&](std::size_t i, std::size_t lower, double t, bool past_end) {
    take(i, past_end ? values[lower] : values[lower] + t * (values[lower + 1] - values[lower]));
  });
}

}  // namespace skinspec::detail
