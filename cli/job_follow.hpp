#pragma once
// A job of skinspecd followed to its end through its events, its progress shown on stderr: a
// bar redrawn in place on a terminal, one line per change otherwise.

#include <string>

#include <nlohmann/json.hpp>

#include "api_client.hpp"

namespace skinspec::cli {

// The job as it ended; Failure kUnreachable when its events end first.
nlohmann::json follow_job(const ApiClient& client, long long job_id);

bool job_finished(const nlohmann::json& job);

// A job's error, {"code", "message"}, as one line: "message (code)".
std::string job_error_text(const nlohmann::json& error);

}  // namespace skinspec::cli
