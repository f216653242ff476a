#include "fit_json.hpp"

#include <cmath>
#include <limits>
#include <optional>

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

nlohmann::json assessment_to_json(const FitResult& fit) {
  nlohmann::json out = nlohmann::json::object();
  if (fit.determination.size() == fit.params.size() && !fit.params.empty()) {
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

namespace {

double number_or_nan(const nlohmann::json& v) {
  return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

std::optional<ParamDetermination> determination_from_json(ModelKind model, const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("determined") || !j["determined"].is_boolean()) return std::nullopt;
  ParamDetermination d;
  if (j["determined"].get<bool>()) return d;
  if (!j.contains("reason") || !j["reason"].is_string()) return std::nullopt;
  const auto status = parse_determination(j["reason"].get<std::string>());
  if (!status) return std::nullopt;
  d.status = *status;
  if (j.contains("correlated_with")) {
    const auto other =
        j["correlated_with"].is_string() ? param_index(model, j["correlated_with"].get<std::string>()) : std::nullopt;
    if (!other) return std::nullopt;
    d.correlated_with = static_cast<int>(*other);
  }
  return d;
}

std::optional<DerivedQuantity> derived_from_json(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("value") || !j.contains("determined") || !j["determined"].is_boolean())
    return std::nullopt;
  DerivedQuantity q;
  q.value = number_or_nan(j["value"]);
  q.standard_error = j.contains("stderr") && j["stderr"].is_number() ? j["stderr"].get<double>()
                                                                     : std::numeric_limits<double>::infinity();
  if (!j["determined"].get<bool>()) {
    const auto status = j.contains("reason") && j["reason"].is_string()
                            ? parse_determination(j["reason"].get<std::string>())
                            : std::nullopt;
    if (!status) return std::nullopt;
    q.status = *status;
  }
  return q;
}

bool determinations_from_json(const nlohmann::json& j, FitResult& fit) {
  const auto specs = model_spec(fit.model).params;
  if (!j.is_object() || j.size() != fit.params.size() || specs.size() != fit.params.size()) return false;
  for (const auto& spec : specs) {
    const auto name = std::string(spec.name);
    const auto d = j.contains(name) ? determination_from_json(fit.model, j[name]) : std::nullopt;
    if (!d) return false;
    fit.determination.push_back(*d);
  }
  return true;
}

bool correlation_from_json(const nlohmann::json& j, FitResult& fit) {
  const std::size_t n = fit.params.size();
  if (!j.is_object() || !j.contains("matrix") || !j["matrix"].is_array() || j["matrix"].size() != n) return false;
  for (const auto& row : j["matrix"]) {
    if (!row.is_array() || row.size() != n) return false;
    for (const auto& v : row) fit.correlation.push_back(number_or_nan(v));
  }
  return true;
}

}  // namespace

bool assessment_from_json(const nlohmann::json& assessment, FitResult& fit) {
  if (!assessment.is_object()) return false;
  if (assessment.contains("determination") && !determinations_from_json(assessment["determination"], fit)) return false;
  if (assessment.contains("derived")) {
    const auto& derived = assessment["derived"];
    const auto saturation = derived.is_object() && derived.contains("oxygen_saturation")
                                ? derived_from_json(derived["oxygen_saturation"])
                                : std::nullopt;
    const auto blood = derived.is_object() && derived.contains("blood_volume_fraction")
                           ? derived_from_json(derived["blood_volume_fraction"])
                           : std::nullopt;
    if (!saturation || !blood) return false;
    fit.oxygen_saturation = *saturation;
    fit.blood_volume_fraction = *blood;
  }
  if (assessment.contains("correlation") && !correlation_from_json(assessment["correlation"], fit)) return false;
  if (assessment.contains("note")) {
    if (!assessment["note"].is_string()) return false;
    fit.coverage_note = assessment["note"].get<std::string>();
  }
  return true;
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
  out.update(assessment_to_json(fit));
  return out;
}

}  // namespace skinspec
