#pragma once
// GET /api/v1/models: what each skin model fits, from its ParamSpec table (name, unit, bounds,
// default, domain, whether it is an amount), with a label for people, the quantities a fit
// derives from its parameters, and the units of its RMSE and ΔE2000. Clients label values with
// this rather than keep tables of their own.

#include <nlohmann/json.hpp>

namespace skinspec::api::detail {

nlohmann::json models_json();
// Its shape, for the OpenAPI document.
nlohmann::json model_list_schema();

}  // namespace skinspec::api::detail
