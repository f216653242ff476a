#pragma once
// Linear resampling, one value at a time: Spectrum::resampled keeps the values, the tristimulus
// sums add them up as they come, so that a fit's colour difference makes no spectrum of 471
// samples twice over to sum it once. Both take the same values, in the same order.

#include <cstddef>
#include <span>

namespace skinspec::detail {

// Calls take(i, value) for each point of `grid_nm` in turn, with the samples (`wavelength_nm`
// increasing, at least two) interpolated linearly there and held constant past their ends.
template <typename Take>
void resample_onto(std::span<const double> wavelength_nm, std::span<const double> values,
                   std::span<const double> grid_nm, Take take) {
  // One sweep along both grids when the target is ordered (the usual case), instead of a
  // search per point.
  std::size_t upper = 1;
  for (std::size_t i = 0; i < grid_nm.size(); ++i) {
    const double w = grid_nm[i];
    if (i > 0 && w < grid_nm[i - 1]) upper = 1;
    if (w <= wavelength_nm.front()) {
      take(i, values.front());
      continue;
    }
    if (w >= wavelength_nm.back()) {
      take(i, values.back());
      continue;
    }
    while (wavelength_nm[upper] < w) ++upper;
    const double t = (w - wavelength_nm[upper - 1]) / (wavelength_nm[upper] - wavelength_nm[upper - 1]);
    take(i, values[upper - 1] + t * (values[upper] - values[upper - 1]));
  }
}

}  // namespace skinspec::detail
