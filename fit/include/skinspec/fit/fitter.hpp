#pragma once
// Least-squares fit of a skin model's parameters to a measured reflectance spectrum (a bounded
// Levenberg-Marquardt of its own from the best points of a coarse search), with standard errors
// and correlations from the covariance, a judgement of what the spectrum determines, and
// colorimetric judgement of the fit.

#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "skinspec/fit/model.hpp"
#include "skinspec/fit/optics.hpp"
#include "skinspec/fit/termination.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/skin_tone.hpp"
#include "skinspec/spectral/spectrum.hpp"

namespace skinspec {

namespace detail {
class ModelCache;
}

// The least a spectrum must cover, inside the model's range, to be fitted: enough for the
// haemoglobin bands, melanin's slope and the red where scattering shows.
inline constexpr double kMinCoverFromNm = 420, kMinCoverToNm = 680;

struct FitOptions {
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  bool lateral_diffusion = true;
  // Optional weight per measured sample (same length as the spectrum); empty = all equal.
  std::vector<double> weights;
  // Parameters held at a value instead of fitted: (index in the model's table, value).
  std::vector<std::pair<std::size_t, double>> held;
  // Where the solver starts instead of the coarse search's best points: an answer for a
  // similar spectrum, such as a neighbouring pixel's (docs/maps.md). Values outside the bounds
  // are brought inside; held parameters keep their held values. Empty: the coarse search.
  std::optional<Params> start;
};

// Whether the spectrum determines a parameter, and if not, why (docs/model.md, "What the
// spectrum determines").
enum class Determination {
  determined,     // its standard error is within its stated precision
  at_bound,       // the estimate sits on a bound of its plausible range
  correlated,     // too imprecise, because the spectrum sees mainly its combination with another parameter
  imprecise,      // too imprecise, without one parameter to blame
  unconstrained,  // its standard error exceeds its plausible range
  held,           // not fitted: held at a value given in FitOptions
};
std::string_view to_string(Determination d);
std::optional<Determination> parse_determination(std::string_view name);

struct ParamDetermination {
  Determination status = Determination::determined;
  int correlated_with = -1;  // the other parameter's index when status is correlated
  bool determined() const { return status == Determination::determined; }
};

// A quantity computed from the parameters, its standard error by the delta method.
struct DerivedQuantity {
  double value = 0;
  double standard_error = 0;  // the delta method's; infinite where it has none
  Determination status = Determination::determined;
  bool determined() const { return status == Determination::determined; }
};

struct FitResult {
  ModelKind model = kDefaultModel;
  std::string site;
  // In the order of the model's ParamSpec table. standard_error is the covariance's for every
  // fitted parameter (infinite for one on a bound, held, or in the null space of the Jacobian);
  // what the spectrum does not determine is reported without it (fit_json, `skinspec fit`). The
  // covariance includes the parameters on a bound, so the others' errors allow for them moving.
  Params params, standard_error;
  std::vector<ParamDetermination> determination;
  // Row-major, params.size() squared; NaN where a parameter has no variance (held, or in the
  // null space of the Jacobian).
  std::vector<double> correlation;
  DerivedQuantity oxygen_saturation;      // oxy / (oxy + deoxy)
  DerivedQuantity blood_volume_fraction;  // of the dermis
  double rmse = 0;                        // unweighted, over the fitted samples
  double max_abs_error = 0;
  double delta_e00_d65 = 0;  // measured against fitted, D65, 2 degree observer
  // ITA° and the melanin and erythema indices of the measured spectrum (not of the fit), as
  // dermatology reports them; empty for a fit stored before they were.
  std::optional<SkinTone> skin_tone;
  // The solver's steps, taken or refused, over every solve that led to the fit.
  int iterations = 0;
  // How the solver ended; empty for a fit stored before terminations were recorded.
  std::optional<Termination> termination;
  // converged(*termination) where that is known; a fit stored before keeps its own.
  bool converged = false;
  std::string solver_message;
  // The samples that were fitted: those of the input inside the model's 380-780 nm.
  std::vector<double> wavelength_nm, measured, fitted;
  std::size_t samples_ignored = 0;  // input samples outside 380-780 nm
  // Set when the fitted samples cover less than the model's range: what was fitted.
  std::string coverage_note;

  double correlation_between(std::size_t i, std::size_t j) const { return correlation[i * params.size() + j]; }
};

class Fitter {
 public:
  // The models it can fit: one SkinOptics per model (at most one of each).
  Fitter(std::vector<SkinOptics> models, Colorimetry colorimetry);
  Fitter(SkinOptics optics, Colorimetry colorimetry);

  // Errors: a model not loaded, unknown site, less than 420-680 nm inside the model range,
  // bad weights, an unknown or out-of-range held parameter.
  std::expected<FitResult, std::string> fit(const Spectrum& measured, const FitOptions& options) const;

  bool has(ModelKind model) const;
  // Requires has(model).
  const SkinOptics& optics(ModelKind model) const;
  const Colorimetry& colorimetry() const { return colorimetry_; }
  // A copy with `optics` replacing (or adding) the tables of its model.
  Fitter with_optics(SkinOptics optics) const;

 private:
  std::vector<SkinOptics> models_;
  Colorimetry colorimetry_;
  ColourWeighting d65_;
  // What fits on one grid share (fit/src/prepared_model.hpp); shared by copies, which fit with
  // the same models, and replaced by with_optics.
  std::shared_ptr<detail::ModelCache> cache_;
};

}  // namespace skinspec
