#pragma once
// Least-squares fit of the five model parameters to a measured reflectance spectrum (Ceres,
// bounded Levenberg-Marquardt from the best points of a coarse search), with standard errors
// from the covariance and colorimetric judgement of the fit.

#include <expected>
#include <string>
#include <vector>

#include "skinspec/fit/model.hpp"
#include "skinspec/fit/optics.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/spectrum.hpp"

namespace skinspec {

inline constexpr Params kLowerBounds = {0, 0, 0, 0, 0};
inline constexpr Params kUpperBounds = {0.2, 500, 500, 500, 500};

struct FitOptions {
  std::string site = "forearm";
  bool lateral_diffusion = true;
  // Optional weight per measured sample (same length as the spectrum); empty = all equal.
  std::vector<double> weights;
};

struct FitResult {
  std::string site;
  Params params{};
  Params standard_error{};
  double rmse = 0;  // unweighted, over the fitted samples
  double max_abs_error = 0;
  double delta_e00_d65 = 0;  // measured against fitted, D65, 2 degree observer
  int iterations = 0;
  bool converged = false;
  std::string solver_message;
  // The samples that were fitted: those of the input inside the model's 380-780 nm.
  std::vector<double> wavelength_nm, measured, fitted;
  std::size_t samples_ignored = 0;  // input samples outside 380-780 nm
};

class Fitter {
 public:
  Fitter(SkinOptics optics, Colorimetry colorimetry);

  // Errors: unknown site, fewer than 400-700 nm inside the model range, bad weights.
  std::expected<FitResult, std::string> fit(const Spectrum& measured, const FitOptions& options) const;

  const SkinOptics& optics() const { return optics_; }
  const Colorimetry& colorimetry() const { return colorimetry_; }

 private:
  SkinOptics optics_;
  Colorimetry colorimetry_;
  ColourWeighting d65_;
};

}  // namespace skinspec
