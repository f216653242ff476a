#include "fit_text.hpp"

#include <fmt/format.h>

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

std::string param_unit(std::string_view model, std::string_view name) {
  const auto kind = parse_model_kind(model);
  if (!kind) return {};
  const auto index = param_index(*kind, name);
  if (!index) return {};
  return unit_text(model_spec(*kind).params[*index].unit);
}

std::string unit_text(std::string_view unit) { return fmt::format("[{}]", unit); }

std::string units_line(std::string_view model, const std::vector<std::string>& names, std::string_view rmse_column,
                       std::string_view delta_e00_column) {
  std::string line = "units:";
  for (const auto& name : names)
    if (const auto unit = param_unit(model, name); !unit.empty()) line += fmt::format(" {} {};", name, unit);
  return line + fmt::format(" {} {}; {} {}; ITA° {}; M, E {}", rmse_column, unit_text(kRmseUnit), delta_e00_column,
                            unit_text(kDeltaE00Unit), unit_text(kItaUnit), unit_text(kSkinIndexUnit));
}

std::string skin_tone_header() { return fmt::format(" {:>6} {:<12} {:>5} {:>5}", "ITA°", "class", "M", "E"); }

std::string skin_tone_cells(const std::optional<SkinTone>& tone) {
  const auto index = [](const std::optional<double>& v) { return v ? fmt::format("{:>5.1f}", *v) : fmt::format("{:>5}", "-"); };
  if (!tone) return fmt::format(" {:>5} {:<12} {:>5} {:>5}", "-", "-", "-", "-");
  return fmt::format(" {:>5.1f} {:<12} {} {}", tone->ita_deg, to_string(tone->ita_class), index(tone->melanin_index),
                     index(tone->erythema_index));
}

std::string not_determined_line(std::string_view reasons_in) {
  const auto where = reasons_in.empty() ? std::string() : fmt::format("reason in {}; ", reasons_in);
  return fmt::format("n.d.: not determined by this spectrum ({}docs/model.md, \"What the spectrum determines\")",
                     where);
}

}  // namespace skinspec::cli
