#pragma once
// A sampled spectrum: values on a strictly increasing wavelength grid in nanometres.
// Construction validates the grid, so every Spectrum in the program is well formed.

#include <expected>
#include <span>
#include <string>
#include <vector>

namespace skinspec {

class Spectrum {
 public:
  // Fails when the sizes differ, there are fewer than two samples, a value is not finite,
  // or the wavelengths are not strictly increasing.
  static std::expected<Spectrum, std::string> create(std::vector<double> wavelength_nm, std::vector<double> values);

  // A uniform grid first, first + step, ... up to and including last (within step/1000).
  static std::vector<double> uniform_grid(double first_nm, double last_nm, double step_nm);

  std::span<const double> wavelengths() const { return wavelength_nm_; }
  std::span<const double> values() const { return values_; }
  std::size_t size() const { return values_.size(); }
  double first_nm() const { return wavelength_nm_.front(); }
  double last_nm() const { return wavelength_nm_.back(); }
  bool covers(double from_nm, double to_nm) const { return first_nm() <= from_nm && last_nm() >= to_nm; }

  // Linear interpolation; outside the grid the nearest end value is held (CIE 15's
  // recommendation for extending a spectrum that stops short of the integration range).
  double at(double wavelength_nm) const;
  Spectrum resampled(std::span<const double> grid_nm) const;

  // Pointwise arithmetic on the union-free case: the other spectrum is resampled onto this
  // spectrum's grid first, so the result always lives on this grid.
  Spectrum operator*(const Spectrum& other) const;
  Spectrum operator/(const Spectrum& other) const;
  Spectrum operator*(double factor) const;

 private:
  Spectrum(std::vector<double> wavelength_nm, std::vector<double> values)
      : wavelength_nm_(std::move(wavelength_nm)), values_(std::move(values)) {}

  std::vector<double> wavelength_nm_;
  std::vector<double> values_;
};

// Linear interpolation of (xs, ys) at x, holding end values outside; xs strictly increasing.
double interpolate(std::span<const double> xs, std::span<const double> ys, double x);

}  // namespace skinspec
