#include "skinspec/fit/fitter.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "determination.hpp"
#include "skinspec/spectral/enum_names.hpp"
#include "prepared_model.hpp"
#include "solver.hpp"

namespace skinspec {

std::string_view to_string(Determination d) {
  switch (d) {
    case Determination::determined:
      return "determined";
    case Determination::at_bound:
      return "at_bound";
    case Determination::correlated:
      return "correlated";
    case Determination::imprecise:
      return "imprecise";
    case Determination::unconstrained:
      return "unconstrained";
    case Determination::held:
      return "held";
  }
  return "unknown";
}

std::optional<Determination> parse_determination(std::string_view name) {
  for (const auto d : {Determination::determined, Determination::at_bound, Determination::correlated,
                       Determination::imprecise, Determination::unconstrained, Determination::held})
    if (to_string(d) == name) return d;
  return std::nullopt;
}

namespace {

constexpr EnumNames<Termination, 6> kTerminationNames{{
    {Termination::function_tolerance, "function_tolerance"},
    {Termination::gradient_tolerance, "gradient_tolerance"},
    {Termination::parameter_tolerance, "parameter_tolerance"},
    {Termination::min_trust_region_radius, "min_trust_region_radius"},
    {Termination::iteration_limit, "iteration_limit"},
    {Termination::failed, "failed"},
}};

}  // namespace

std::string_view to_string(Termination t) { return name_of(kTerminationNames, t); }

std::optional<Termination> parse_termination(std::string_view name) { return value_named(kTerminationNames, name); }

std::span<const std::pair<Termination, std::string_view>> termination_names() { return kTerminationNames; }

bool converged(Termination t) { return t != Termination::iteration_limit && t != Termination::failed; }

namespace {

// The measured samples inside the model's range, with their weights.
struct FittedSamples {
  std::vector<double> wavelength_nm, measured, weights;
  std::size_t ignored = 0;
};

std::expected<FittedSamples, std::string> samples_inside(const Spectrum& measured, const FitOptions& options) {
  if (!options.weights.empty() && options.weights.size() != measured.size())
    return std::unexpected(fmt::format("{} weights for {} samples", options.weights.size(), measured.size()));
  FittedSamples s;
  for (auto* column : {&s.wavelength_nm, &s.measured, &s.weights}) column->reserve(measured.size());
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double w = measured.wavelengths()[i];
    if (w < SkinOptics::kFirstNm || w > SkinOptics::kLastNm) {
      ++s.ignored;
      continue;
    }
    const double weight = options.weights.empty() ? 1.0 : options.weights[i];
    if (!(weight >= 0) || !std::isfinite(weight))
      return std::unexpected(fmt::format("weight at {} nm must be a finite number >= 0", w));
    s.wavelength_nm.push_back(w);
    s.measured.push_back(measured.values()[i]);
    s.weights.push_back(weight);
  }
  if (s.wavelength_nm.size() < 2 || s.wavelength_nm.front() > kMinCoverFromNm || s.wavelength_nm.back() < kMinCoverToNm)
    return std::unexpected(fmt::format("the spectrum must cover {}-{} nm inside the model's {}-{} nm", kMinCoverFromNm,
                                       kMinCoverToNm, SkinOptics::kFirstNm, SkinOptics::kLastNm));
  return s;
}

// Which parameters are held, and at what; an error for an unknown index or a value outside the
// parameter's plausible range.
std::expected<std::pair<std::vector<bool>, Params>, std::string> held_parameters(const FitOptions& options) {
  const auto specs = model_spec(options.model).params;
  std::vector<bool> held(specs.size(), false);
  Params values(specs.size(), 0.0);
  for (const auto& [index, value] : options.held) {
    if (index >= specs.size())
      return std::unexpected(fmt::format("model {} has no parameter {} to hold", to_string(options.model), index));
    const ParamSpec& spec = specs[index];
    if (!(value >= spec.lower && value <= spec.upper))
      return std::unexpected(
          fmt::format("{} can only be held within {}..{}, not at {}", spec.name, spec.lower, spec.upper, value));
    held[index] = true;
    values[index] = value;
  }
  return std::pair{std::move(held), std::move(values)};
}

// The model at the solution: from the solver's residuals sqrt(w) (model - measured) where every
// weight is positive, which spares evaluating the model once more (a sixth of a fit started
// near its answer, as a map's pixels are); else evaluated.
std::vector<double> fitted_spectrum(const detail::Solution& best, const std::vector<double>& measured,
                                    const std::vector<double>& sqrt_weights, const detail::SpectrumModel& columns) {
  const auto n = static_cast<Eigen::Index>(measured.size());
  if (best.residuals.size() != n || !std::ranges::all_of(sqrt_weights, [](double w) { return w > 0; }))
    return detail::reflectance(columns, best.params);
  std::vector<double> fitted(measured.size());
  // A weight of 1 divides by nothing: most fits weigh every sample 1.
  for (std::size_t i = 0; i < fitted.size(); ++i) {
    const double residual = best.residuals(static_cast<Eigen::Index>(i));
    fitted[i] = measured[i] + (sqrt_weights[i] == 1 ? residual : residual / sqrt_weights[i]);
  }
  return fitted;
}

std::string coverage_note(const FitResult& r) {
  const double first = r.wavelength_nm.front(), last = r.wavelength_nm.back();
  if (first <= SkinOptics::kFirstNm + 5 && last >= SkinOptics::kLastNm - 5) return {};
  return fmt::format(
      "fitted over {}-{} nm of the model's {}-{} nm; what the spectrum leaves out widens the "
      "standard errors",
      first, last, SkinOptics::kFirstNm, SkinOptics::kLastNm);
}

}  // namespace

Fitter::Fitter(std::vector<SkinOptics> models, Colorimetry colorimetry)
    : models_(std::move(models)),
      colorimetry_(std::move(colorimetry)),
      d65_(colorimetry_.weighting(*colorimetry_.illuminant("D65"))),
      cache_(std::make_shared<detail::ModelCache>(d65_)) {}

Fitter::Fitter(SkinOptics optics, Colorimetry colorimetry)
    : Fitter(std::vector<SkinOptics>{std::move(optics)}, std::move(colorimetry)) {}

bool Fitter::has(ModelKind model) const {
  return std::ranges::any_of(models_, [&](const SkinOptics& o) { return o.model() == model; });
}

const SkinOptics& Fitter::optics(ModelKind model) const {
  return *std::ranges::find_if(models_, [&](const SkinOptics& o) { return o.model() == model; });
}

Fitter Fitter::with_optics(SkinOptics optics) const {
  Fitter copy = *this;
  const auto it = std::ranges::find_if(copy.models_, [&](const SkinOptics& o) { return o.model() == optics.model(); });
  if (it == copy.models_.end()) copy.models_.push_back(std::move(optics));
  else *it = std::move(optics);
  copy.cache_ = std::make_shared<detail::ModelCache>(d65_);
  return copy;
}

std::expected<FitResult, std::string> Fitter::fit(const Spectrum& measured, const FitOptions& options) const {
  if (!has(options.model)) return std::unexpected(fmt::format("the {} model is not loaded", to_string(options.model)));
  const SkinOptics& skin = optics(options.model);
  const auto site = skin.site(options.site);
  if (!site) return std::unexpected(site.error());
  auto samples = samples_inside(measured, options);
  if (!samples) return std::unexpected(samples.error());
  auto held = held_parameters(options);
  if (!held) return std::unexpected(held.error());
  if (options.start && !std::ranges::all_of(*options.start, [](double v) { return std::isfinite(v); }))
    return std::unexpected("a start must be finite numbers");
  if (options.start && options.start->size() != model_spec(options.model).params.size())
    return std::unexpected(fmt::format("a start of {} values for the {} model's {} parameters", options.start->size(),
                                       to_string(options.model), model_spec(options.model).params.size()));

  FitResult result;
  result.model = options.model;
  result.site = site->name;
  result.wavelength_nm = std::move(samples->wavelength_nm);
  result.measured = std::move(samples->measured);
  result.samples_ignored = samples->ignored;
  const detail::PreparedModel& prepared = cache_->get(skin, *site, result.wavelength_nm, options.lateral_diffusion);
  const SkinModel& model = prepared.model;
  std::vector<double> sqrt_weights(samples->weights.size());
  // Most fits weigh every sample 1, and their square roots, taken one by one (std::sqrt may set
  // errno), were a fifth of the time spent in this function's own code.
  std::ranges::transform(samples->weights, sqrt_weights.begin(), [](double w) { return w == 1 ? 1 : std::sqrt(w); });
  const auto& [held_flags, held_values] = *held;
  const bool holds_any = std::ranges::any_of(held_flags, std::identity{});
  // The coarse search's layers depend on what is held; the prepared ones hold nothing.
  const detail::CoarseLayers coarse =
      holds_any ? detail::coarse_layers(model, held_flags, held_values) : detail::CoarseLayers{};
  const detail::Problem problem{model,           prepared.columns,
                                prepared.bounds, holds_any ? coarse : prepared.coarse,
                                result.measured, samples->weights,
                                sqrt_weights,    held_flags,
                                held_values,     options.start ? &*options.start : nullptr};

  const detail::Solution best = detail::solve(problem);
  result.params = best.params;
  result.iterations = best.iterations;
  result.termination = best.termination;
  result.converged = converged(best.termination);
  result.solver_message = best.message;
  result.fitted = fitted_spectrum(best, result.measured, sqrt_weights, prepared.columns);
  auto uncertainty =
      detail::assess_uncertainty(options.model, best.jacobian, best.cost, best.params, problem.held, best.pinned);
  result.standard_error = std::move(uncertainty.standard_error);
  result.correlation = std::move(uncertainty.correlation);
  result.determination = std::move(uncertainty.determination);
  result.oxygen_saturation = uncertainty.oxygen_saturation;
  result.blood_volume_fraction = uncertainty.blood_volume_fraction;

  double sum_squares = 0;
  for (std::size_t i = 0; i < result.fitted.size(); ++i) {
    const double r = result.fitted[i] - result.measured[i];
    sum_squares += r * r;
    result.max_abs_error = std::max(result.max_abs_error, std::abs(r));
  }
  result.rmse = std::sqrt(sum_squares / static_cast<double>(result.fitted.size()));
  const auto [measured_lab, fitted_lab] = Colorimetry::labs(result.measured, result.fitted, prepared.d65);
  result.delta_e00_d65 = delta_e2000(measured_lab, fitted_lab);
  result.skin_tone = skin_tone(result.wavelength_nm, result.measured, measured_lab);
  result.coverage_note = coverage_note(result);
  return result;
}

}  // namespace skinspec
