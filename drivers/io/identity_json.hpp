#pragma once
// A meter's identity as JSON, the one shape the service's instrument state and
// `skinspec measure --json` both show. Apart from drivers/ so that the drivers need no JSON.

#include <nlohmann/json.hpp>

#include "skinspec/drivers/instrument.hpp"

namespace skinspec::drivers {

// {"model": profile id or null (a model skinspec does not know), "reported_model", "family",
//  "serial_number", "firmware" (null where the meter reports none), "grid": {"first_nm",
//  "last_nm", "step_nm", "points"}, "warnings": [...]}
nlohmann::json identity_json(const Identity& identity);

// The same keys, null (and no warnings), for a meter not reached yet.
nlohmann::json no_identity_json();

}  // namespace skinspec::drivers
