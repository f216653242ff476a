#pragma once
// Test helper: a finished job's error, as the service answers it, in one line.

#include <string>

#include <nlohmann/json.hpp>

namespace skinspec::testing {

// A finished job's error as "code: message" ("" when it has none), for prefix checks.
inline std::string job_error_text(const nlohmann::json& job) {
  const auto it = job.find("error");
  if (it == job.end() || !it->is_object()) return "";
  return it->value("code", "") + ": " + it->value("message", "");
}

}  // namespace skinspec::testing
