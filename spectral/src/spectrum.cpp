#include "skinspec/spectral/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "resample.hpp"

namespace skinspec {

std::expected<Spectrum, std::string> Spectrum::create(std::vector<double> wavelength_nm, std::vector<double> values) {
  if (wavelength_nm.size() != values.size())
    return std::unexpected(fmt::format("{} wavelengths but {} values", wavelength_nm.size(), values.size()));
  if (values.size() < 2) return std::unexpected(std::string("a spectrum needs at least two samples"));
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(wavelength_nm[i]) || !std::isfinite(values[i]))
      return std::unexpected(fmt::format("sample {} is not a finite number", i));
    if (i > 0 && !(wavelength_nm[i] > wavelength_nm[i - 1]))
      return std::unexpected(
          fmt::format("wavelength {} nm does not increase after {} nm", wavelength_nm[i], wavelength_nm[i - 1]));
  }
  return Spectrum(std::move(wavelength_nm), std::move(values));
}

std::vector<double> Spectrum::uniform_grid(double first_nm, double last_nm, double step_nm) {
  std::vector<double> grid;
  if (!(step_nm > 0) || last_nm < first_nm) return grid;
  const double tolerance = step_nm / 1000;
  for (std::size_t i = 0;; ++i) {
    const double w = first_nm + static_cast<double>(i) * step_nm;
    if (w > last_nm + tolerance) break;
    grid.push_back(w);
  }
  return grid;
}

double interpolate(std::span<const double> xs, std::span<const double> ys, double x) {
  if (x <= xs.front()) return ys.front();
  if (x >= xs.back()) return ys.back();
  const auto upper = std::upper_bound(xs.begin(), xs.end(), x);
  const auto i = static_cast<std::size_t>(upper - xs.begin());
  const double t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
  return ys[i - 1] + t * (ys[i] - ys[i - 1]);
}

double Spectrum::at(double wavelength_nm) const { return interpolate(wavelength_nm_, values_, wavelength_nm); }

Spectrum Spectrum::resampled(std::span<const double> grid_nm) const {
  std::vector<double> values(grid_nm.size());
  detail::resample_onto(wavelength_nm_, values_, grid_nm, [&](std::size_t i, double v) { values[i] = v; });
  return Spectrum({grid_nm.begin(), grid_nm.end()}, std::move(values));
}

Spectrum Spectrum::operator*(const Spectrum& other) const {
  Spectrum result = *this;
  for (std::size_t i = 0; i < size(); ++i) result.values_[i] *= other.at(wavelength_nm_[i]);
  return result;
}

Spectrum Spectrum::operator/(const Spectrum& other) const {
  Spectrum result = *this;
  for (std::size_t i = 0; i < size(); ++i) result.values_[i] /= other.at(wavelength_nm_[i]);
  return result;
}

Spectrum Spectrum::operator*(double factor) const {
  Spectrum result = *this;
  for (double& v : result.values_) v *= factor;
  return result;
}

}  // namespace skinspec
