#include "skinspec/records/fit_record.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <type_traits>

#include "fit_json.hpp"
#include "skinspec/version.hpp"

namespace skinspec::records {

namespace {

// The values a stored fit and a fit result share, listed once for both directions:
// `assign(stored, fitted)` copies one of them whichever way the caller wants.
template <typename StoredFit, typename Result, typename Assign>
void each_shared_value(StoredFit& f, Result& r, Assign assign) {
  assign(f.site, r.site);
  assign(f.rmse, r.rmse);
  assign(f.max_abs_error, r.max_abs_error);
  assign(f.delta_e00_d65, r.delta_e00_d65);
  assign(f.iterations, r.iterations);
  assign(f.converged, r.converged);
  assign(f.solver_summary, r.solver_message);
  assign(f.wavelength_nm, r.wavelength_nm);
  assign(f.measured, r.measured);
  assign(f.fitted, r.fitted);
  assign(f.samples_ignored, r.samples_ignored);
}

}  // namespace

std::string model_version() { return "skinspec " + std::string(kVersion); }

store::Fit to_store_fit(const FitResult& result, const FitOptions& options, const SkinOptics& optics) {
  store::Fit f;
  each_shared_value(f, result, [](auto& stored, const auto& fitted) {
    stored = static_cast<std::decay_t<decltype(stored)>>(fitted);
  });
  f.model = std::string(to_string(result.model));
  const auto specs = model_spec(result.model).params;
  for (std::size_t i = 0; i < result.params.size() && i < specs.size(); ++i)
    f.params.push_back({std::string(specs[i].name), result.params[i], result.standard_error[i]});
  f.assessment = assessment_text(result);
  f.options = options_text(options);
  f.model_version = model_version();
  f.tables_digest = optics.tables_digest();
  f.constants_digest = optics.constants_digest();
  return f;
}

std::expected<store::Fit, std::string> fitted(const Fitter& fitter, const store::SpectralSamples& reflectance,
                                              const FitOptions& options) {
  auto spectrum = Spectrum::create(reflectance.wavelength_nm, reflectance.values);
  if (!spectrum) return std::unexpected(spectrum.error());
  auto result = fitter.fit(*spectrum, options);
  if (!result) return std::unexpected(result.error());
  return to_store_fit(*result, options, fitter.optics(options.model));
}

std::expected<FitResult, std::string> to_fit_result(const store::Fit& fit) {
  const auto model = parse_model_kind(fit.model);
  if (!model)
    return std::unexpected(fmt::format("fit {} is of model '{}', which this version does not know (it knows {})",
                                       fit.id, fit.model, model_names()));
  const auto specs = model_spec(*model).params;
  if (fit.params.size() != specs.size())
    return std::unexpected(fmt::format("fit {} has {} parameters; the {} model has {}", fit.id, fit.params.size(),
                                       fit.model, specs.size()));
  FitResult r;
  each_shared_value(
      fit, r, [](const auto& stored, auto& fitted) { fitted = static_cast<std::decay_t<decltype(fitted)>>(stored); });
  r.model = *model;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (fit.params[i].name != specs[i].name)
      return std::unexpected(fmt::format("fit {}: parameter {} is '{}' where the {} model has '{}'", fit.id, i + 1,
                                         fit.params[i].name, fit.model, specs[i].name));
    r.params.push_back(fit.params[i].value);
    r.standard_error.push_back(fit.params[i].standard_error);
  }
  const auto assessment = nlohmann::json::parse(fit.assessment, nullptr, false);
  if (assessment.is_discarded() || !assessment_from_json(assessment, r))
    return std::unexpected(fmt::format("fit {}: its assessment is not one this version reads", fit.id));
  return r;
}

}  // namespace skinspec::records
