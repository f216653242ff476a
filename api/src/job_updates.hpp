#pragma once
// The ends a fitting job's record is given (FitJobs: imports, refits, maps), in one place.

#include <optional>
#include <string>

#include "skinspec/api/job_board.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

inline store::JobUpdate ended(store::JobState state, std::optional<store::JobError> error,
                              std::optional<std::string> result = std::nullopt) {
  return {state, std::move(error), std::move(result), std::nullopt};
}

// A job that failed with `code`.
inline store::JobUpdate failed(store::JobErrorCode code, std::string message) {
  return ended(store::JobState::failed, store::JobError{code, std::move(message)});
}

// The end of a job told to stop: cancelled by request, or by the service stopping.
inline store::JobUpdate stopped_update(store::JobErrorCode why, std::optional<std::string> result = std::nullopt) {
  return ended(store::JobState::cancelled, stop_error(why), std::move(result));
}

}  // namespace skinspec::api::detail
