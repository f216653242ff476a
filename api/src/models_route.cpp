#include "models_route.hpp"

#include <algorithm>
#include <array>
#include <string_view>
#include <utility>

#include "skinspec/fit/model_spec.hpp"
#include "skinspec/spectral/skin_tone.hpp"

namespace skinspec::api::detail {

namespace {

using nlohmann::json;

// The label of every parameter, derived quantity and figure of fit quality, by name: the one
// place they are written.
constexpr std::pair<std::string_view, std::string_view> kLabels[] = {
    {"surface_reflectance", "Surface reflectance"},
    {"melanin", "Melanin"},
    {"oxyhemoglobin", "Oxy-haemoglobin"},
    {"deoxyhemoglobin", "Deoxy-haemoglobin"},
    {"total_hemoglobin", "Total haemoglobin"},
    {"oxygen_saturation", "Oxygen saturation"},
    {"bilirubin", "Bilirubin"},
    {"dermis_scattering", "Dermal scattering"},
    {"dermis_scattering_power", "Dermal scattering power"},
    {"blood_volume_fraction", "Blood volume fraction"},
    {"rmse", "RMSE"},
    {"delta_e00_d65", "ΔE2000 (D65)"},
    {"ita_deg", "ITA°"},
    {"ita_class", "ITA class"},
    {"melanin_index", "Melanin index (Diffey)"},
    {"erythema_index", "Erythema index (Diffey)"},
};

std::string label_of(std::string_view name) {
  const auto* it = std::ranges::find(kLabels, name, &std::pair<std::string_view, std::string_view>::first);
  return std::string(it != std::end(kLabels) ? it->second : name);
}

json param_json(const ParamSpec& spec) {
  return {{"name", spec.name},         {"label", label_of(spec.name)},
          {"unit", spec.unit},         {"bounds", {spec.lower, spec.upper}},
          {"default", spec.initial},   {"domain", {spec.domain_lower, spec.domain_upper}},
          {"absorber", spec.absorber}, {"source", spec.source}};
}

// A quantity a fit gives besides its parameters: its name there, label and unit.
json quantity_json(std::string_view name, std::string_view unit) {
  return {{"name", name}, {"label", label_of(name)}, {"unit", unit}};
}

// The quantities every fit derives (docs/model.md, "What the spectrum determines"): the
// saturation in the unit of the extended model's parameter that states it, the blood as a
// share of the dermis's volume.
json derived_json() {
  const ParamSpec& saturation = model_spec(ModelKind::extended).params[kOxygenSaturation];
  return json::array({quantity_json(saturation.name, saturation.unit),
                      quantity_json("blood_volume_fraction", "fraction of the dermis")});
}

// How well every fit matches its spectrum: its RMSE and colour difference, as the fit gives them.
json fit_quality_json() {
  json figures = json::array();
  for (const FitQualitySpec& figure : kFitQuality) figures.push_back(quantity_json(figure.name, figure.unit));
  return figures;
}

// The skin-tone descriptors every fit gives of its measured spectrum (fit JSON "skin_tone";
// docs/model.md, "Skin tone"), whatever the model.
json skin_tone_json() {
  return json::array({quantity_json("ita_deg", kItaUnit), quantity_json("ita_class", ""),
                      quantity_json("melanin_index", kSkinIndexUnit), quantity_json("erythema_index", kSkinIndexUnit)});
}

json string_schema() { return {{"type", "string"}}; }
json described(json schema, const char* description) {
  schema["description"] = description;
  return schema;
}
json pair_schema() { return {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2}, {"maxItems", 2}}; }

}  // namespace

json models_json() {
  json models = json::array();
  for (const ModelKind kind : kModelKinds) {
    json params = json::array();
    for (const ParamSpec& spec : model_spec(kind).params) params.push_back(param_json(spec));
    models.push_back({{"name", to_string(kind)},
                      {"params", params},
                      {"derived", derived_json()},
                      {"fit_quality", fit_quality_json()},
                      {"skin_tone", skin_tone_json()}});
  }
  return {{"default", to_string(kDefaultModel)}, {"models", models}};
}

json model_list_schema() {
  const json param = {
      {"type", "object"},
      {"properties",
       {{"name", string_schema()},
        {"label", string_schema()},
        {"unit", string_schema()},
        {"bounds", described(pair_schema(), "the fit's range: where the parameter can plausibly be")},
        {"default", described({{"type", "number"}}, "where a held parameter stays")},
        {"domain", described(pair_schema(), "where the equations hold: the values a render may set")},
        {"absorber", described({{"type", "boolean"}}, "an amount of an absorber, which a render may also scale")},
        {"source", described(string_schema(), "why this range, in brief")}}}};
  const json quantity = {
      {"type", "object"},
      {"properties", {{"name", string_schema()}, {"label", string_schema()}, {"unit", string_schema()}}}};
  const json model = {{"type", "object"},
                      {"properties",
                       {{"name", string_schema()},
                        {"params", {{"type", "array"}, {"items", param}}},
                        {"derived", {{"type", "array"}, {"items", quantity}}},
                        {"fit_quality", described({{"type", "array"}, {"items", quantity}},
                                                  "how well a fit matches its spectrum: rmse, delta_e00_d65")},
                        {"skin_tone", described({{"type", "array"}, {"items", quantity}},
                                                "the measured spectrum's ITA° and class, melanin and erythema "
                                                "indices, as each fit's skin_tone gives them")}}}};
  return {{"type", "object"},
          {"properties", {{"default", string_schema()}, {"models", {{"type", "array"}, {"items", model}}}}}};
}

}  // namespace skinspec::api::detail
