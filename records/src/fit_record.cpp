#include "skinspec/records/fit_record.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <type_traits>

#include "skinspec/version.hpp"

namespace skinspec::records {

namespace {

static_assert(store::kFitParamCount == kPaperParamCount, "the store keeps the paper model's parameters");

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

store::Fit to_store_fit(const FitResult& result, const FitOptions& options, const std::string& tables_digest) {
  store::Fit f;
  each_shared_value(f, result, [](auto& stored, const auto& fitted) {
    stored = static_cast<std::decay_t<decltype(stored)>>(fitted);
  });
  // The store keeps the paper model's five parameters; the service fits with it alone.
  std::copy_n(result.params.begin(), std::min(result.params.size(), f.params.size()), f.params.begin());
  std::copy_n(result.standard_error.begin(), std::min(result.standard_error.size(), f.standard_error.size()),
              f.standard_error.begin());
  f.options = nlohmann::json{{"site", options.site}, {"lateral_diffusion", options.lateral_diffusion}}.dump();
  f.model_version = model_version();
  f.tables_digest = tables_digest;
  return f;
}

FitResult to_fit_result(const store::Fit& fit) {
  FitResult r;
  each_shared_value(
      fit, r, [](const auto& stored, auto& fitted) { fitted = static_cast<std::decay_t<decltype(fitted)>>(stored); });
  r.model = ModelKind::paper;
  r.params.assign(fit.params.begin(), fit.params.end());
  r.standard_error.assign(fit.standard_error.begin(), fit.standard_error.end());
  return r;
}

}  // namespace skinspec::records
