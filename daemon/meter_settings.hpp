#pragma once
// The meter's settings a measurement job asks for: the API's request as the drivers' options (the
// one mapping), held to what the meter takes when the job is posted, and what it takes as JSON
// (GET /api/v1/instrument's "capabilities", for the console).

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/measure_settings.hpp"

namespace skinspec::daemon {

drivers::MeasureOptions measure_options(const api::MeasureRequest& request);

// What the meter takes: its model's limits (or before a model is known, any model's) and the
// apertures it lists, once read.
struct MeterSettings {
  drivers::SettingLimits limits;
  std::optional<std::vector<std::string>> apertures;  // nullopt: not read yet
};

// A 422 naming what the meter takes, for the first setting of `request` it does not take.
std::optional<api::ApiError> check_settings(const MeterSettings& meter, const api::MeasureRequest& request);

// {"model", "integration_ms": {"min", "max", "max_extended"}, "averages": {"min", "max"}, "sync":
// {"modes", "min_hz", "max_hz", "whole_hz"}, "extended_sensitivity", "apertures"}; null before a
// model is known.
nlohmann::json capabilities_json(const MeterSettings& meter);

}  // namespace skinspec::daemon
