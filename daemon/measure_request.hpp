#pragma once
// A measurement job's request as its record keeps it (jobs.request), and back: the one shape,
// written by the program that takes the job and read by the bench that runs it.

#include <optional>
#include <string>

#include "skinspec/api/acquisition.hpp"

namespace skinspec::daemon {

std::string measure_request_json(const api::MeasureRequest& request);
// nullopt for text that is not a measurement's request.
std::optional<api::MeasureRequest> parse_measure_request(const std::string& text);

}  // namespace skinspec::daemon
