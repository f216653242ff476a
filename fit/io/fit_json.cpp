#include "fit_json.hpp"

#include <cmath>
#include <limits>

namespace skinspec {

namespace {

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

std::string_view param_name(ModelKind model, std::size_t i) { return model_spec(model).params[i].name; }

nlohmann::json determination_json(const FitResult& fit, const ParamDetermination& d) {
  nlohmann::json out = {{"determined", d.determined()}};
  if (!d.determined()) out["reason"] = to_string(d.status);
  if (d.correlated_with >= 0)
    out["correlated_with"] = param_name(fit.model, static_cast<std::size_t>(d.correlated_with));
  return out;
}

nlohmann::json derived_json(const DerivedQuantity& q) {
  nlohmann::json out = {{"value", finite_or_null(q.value)},
                        {"stderr", q.determined() ? finite_or_null(q.standard_error) : nlohmann::json()},
                        {"determined", q.determined()}};
  if (!q.determined()) out["reason"] = to_string(q.status);
  return out;
}

// The parameters' names in order, and their correlation matrix row by row (null where a
// parameter was not fitted).
nlohmann::json correlation_json(const FitResult& fit) {
  const std::size_t n = fit.params.size();
  nlohmann::json names = nlohmann::json::array(), matrix = nlohmann::json::array();
  for (std::size_t i = 0; i < n; ++i) {
    names.push_back(param_name(fit.model, i));
    nlohmann::json row = nlohmann::json::array();
    for (std::size_t j = 0; j < n; ++j) row.push_back(finite_or_null(fit.correlation_between(i, j)));
    matrix.push_back(std::move(row));
  }
  return {{"params", names}, {"matrix", matrix}};
}

}  // namespace

nlohmann::json params_to_json(ModelKind model, const Params& params) {
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < params.size(); ++i) out[std::string(param_name(model, i))] = finite_or_null(params[i]);
  return out;
}

nlohmann::json fit_to_json(std::string_view name, const FitResult& fit) {
  const bool judged = fit.determination.size() == fit.params.size();
  Params shown_error = fit.standard_error;
  for (std::size_t i = 0; judged && i < shown_error.size(); ++i)
    if (!fit.determination[i].determined()) shown_error[i] = std::numeric_limits<double>::infinity();
  nlohmann::json out = {
      {"name", name},
      {"model", to_string(fit.model)},
      {"site", fit.site},
      {"params", params_to_json(fit.model, fit.params)},
      {"stderr", params_to_json(fit.model, shown_error)},
      {"rmse", fit.rmse},
      {"max_abs_error", fit.max_abs_error},
      {"delta_e00_d65", fit.delta_e00_d65},
      {"iterations", fit.iterations},
      {"converged", fit.converged},
      {"samples_ignored", fit.samples_ignored},
      {"wavelength_nm", fit.wavelength_nm},
      {"measured", fit.measured},
      {"fitted", fit.fitted},
  };
  if (judged) {
    nlohmann::json determination = nlohmann::json::object();
    for (std::size_t i = 0; i < fit.params.size(); ++i)
      determination[std::string(param_name(fit.model, i))] = determination_json(fit, fit.determination[i]);
    out["determination"] = std::move(determination);
    out["derived"] = {{"oxygen_saturation", derived_json(fit.oxygen_saturation)},
                      {"blood_volume_fraction", derived_json(fit.blood_volume_fraction)}};
  }
  if (fit.correlation.size() == fit.params.size() * fit.params.size() && !fit.params.empty())
    out["correlation"] = correlation_json(fit);
  if (!fit.coverage_note.empty()) out["note"] = fit.coverage_note;
  return out;
}

}  // namespace skinspec
