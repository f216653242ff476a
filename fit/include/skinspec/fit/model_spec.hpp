#pragma once
// The skin models by name, and what each one fits, as data: its parameters (name, unit,
// plausible range, default, source) and its tuned constants (name, search range). Code that
// differs between the models reads these tables; only the equations themselves (model.hpp)
// are written per model. docs/model.md explains every entry.

#include <algorithm>
#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec {

// `paper`: eq. 1 of Doi, Tanaka & Tominaga with its five unknowns, kept to reproduce the seed.
// `extended`: the same layers with blood as total haemoglobin and oxygen saturation packed in
// vessels, a free dermal scattering amplitude and power, within plausible ranges, and tuned
// corrections of the melanin and baseline absorption spectra.
enum class ModelKind { paper, extended };
inline constexpr ModelKind kDefaultModel = ModelKind::extended;
inline constexpr std::array<ModelKind, 2> kModelKinds = {ModelKind::paper, ModelKind::extended};

std::string_view to_string(ModelKind kind);
std::optional<ModelKind> parse_model_kind(std::string_view name);
// "paper, extended": for messages and help.
std::string model_names();

// The parameter vector of a fit, in the order of its model's ParamSpec table.
using Params = std::vector<double>;

// Indices of the paper's parameters.
enum Param : int { kSurfaceReflectance, kMelanin, kOxyhemoglobin, kDeoxyhemoglobin, kBilirubin };
inline constexpr int kPaperParamCount = 5;

// Indices of the extended model's parameters; the first two and bilirubin sit where the
// paper has them.
enum ExtendedParam : int {
  kTotalHemoglobin = 2,
  kOxygenSaturation = 3,
  kDermisScattering = 5,
  kDermisScatteringPower = 6,
};
inline constexpr int kExtendedParamCount = 7;
// The most parameters any model has.
inline constexpr std::size_t kMaxParamCount = std::max(kPaperParamCount, kExtendedParamCount);

struct ParamSpec {
  std::string_view name;
  std::string_view unit;
  double lower, upper;                // the fit's bounds: the range the parameter can plausibly take
  double initial;                     // the default: where a held parameter stays, and `skinspec model`'s value
  double domain_lower, domain_upper;  // where the equations hold: what `model` and `render` accept
  // The largest standard error at which the parameter counts as determined:
  // max(precision_absolute, precision_relative * |value|) (docs/model.md, "What the spectrum
  // determines").
  double precision_absolute, precision_relative;
  std::string_view source;  // why this range, in brief (docs/model.md gives the full citation)
  bool absorber = false;    // an amount of an absorber, whose lower bound is none of it
};

// What a fit's figures of its match to the spectrum are given in (docs/model.md, "The fit"):
// the RMSE, and the largest absolute error, in reflectance; the colour difference as CIEDE2000.
// Every model's fit gives them, under the names of kFitQuality.
inline constexpr std::string_view kRmseUnit = "reflectance, as a fraction";
inline constexpr std::string_view kDeltaE00Unit = "CIEDE2000 of measured and fitted colour under D65";

struct FitQualitySpec {
  std::string_view name;  // as a fit gives it
  std::string_view unit;
};
inline constexpr std::array<FitQualitySpec, 2> kFitQuality = {{{"rmse", kRmseUnit}, {"delta_e00_d65", kDeltaE00Unit}}};

// How a tuned constant is searched: on its logarithm (a positive scale or length) or as is
// (a coefficient that may be negative).
enum class ConstantScale { logarithmic, linear };

struct ConstantSpec {
  std::string_view name;
  double lower, upper;  // plausible range the tuning may search
  double textbook;      // the untuned starting point
  ConstantScale scale;
};

struct ModelSpec {
  ModelKind kind;
  std::span<const ParamSpec> params;
  std::span<const ConstantSpec> constants;
  std::string_view constants_file;  // in the data directory
  // The body sites' anatomy (in the data directory): which table, its column of the
  // melanin-bearing epidermis's thickness, and its column of the stratum corneum's (empty: the
  // model has none, its epidermis is the whole epidermis). docs/model.md, "Body sites".
  std::string_view sites_file, epidermis_column, stratum_corneum_column;
  // How far, as a share of its range, the solver may carry a parameter past a bound before it
  // is pinned there (docs/model.md, "The fit"); absorbers may always dip a little below zero.
  double bound_overshoot;
  // How many of the coarse search's best points the solver refines (docs/model.md, "The fit").
  std::size_t starts;
  // The parameters whose bounds are no physical value (a fraction, an exponent; not an amount,
  // whose zero is one), and the largest share of fits of healthy skin that may leave one of them
  // on a bound: beyond it the bound, not the skin, decides the value (docs/model.md, "Body
  // sites"). The tuning keeps its training fits within it.
  std::span<const int> bound_watched;
  double most_at_bound;
};

const ModelSpec& model_spec(ModelKind kind);
// Index of a parameter by name; nullopt when the model has no such parameter.
std::optional<std::size_t> param_index(ModelKind kind, std::string_view name);
// Every parameter at its default.
Params default_params(ModelKind kind);

// The most terms a baseline-absorption correction may have: Legendre polynomials of degree
// 0, 1, ... in x = (lambda - 580 nm) / 200 nm, each with a tuned coefficient (docs/model.md,
// "Baseline absorption correction").
inline constexpr std::size_t kMaxBaselineTerms = 8;

}  // namespace skinspec
