#include "fit_text.hpp"

#include "skinspec/fit/model_spec.hpp"

namespace skinspec::cli {

std::vector<std::string> param_names(const nlohmann::json& fit) {
  std::vector<std::string> names;
  const auto model = fit.contains("model") && fit["model"].is_string()
                         ? parse_model_kind(fit["model"].get<std::string>())
                         : std::nullopt;
  if (model) {
    for (const auto& spec : model_spec(*model).params) names.emplace_back(spec.name);
  } else if (fit.contains("params") && fit["params"].is_object()) {
    for (const auto& item : fit["params"].items()) names.push_back(item.key());
  }
  return names;
}

std::optional<std::string> not_determined(const nlohmann::json& fit, const std::string& name) {
  if (!fit.contains("determination") || !fit["determination"].contains(name)) return std::nullopt;
  const auto& d = fit["determination"][name];
  if (!d.is_object() || d.value("determined", true)) return std::nullopt;
  std::string reason = d.value("reason", "not determined");
  if (d.contains("correlated_with") && d["correlated_with"].is_string())
    reason += " with " + d["correlated_with"].get<std::string>();
  return reason;
}

}  // namespace skinspec::cli
