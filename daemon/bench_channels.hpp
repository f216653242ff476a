#pragma once
// What the programs of one database tell each other (docs/store.md, "Benches"): the channels
// and the one shape of each notice.

#include <optional>
#include <string>
#include <string_view>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::daemon {

// A bench's name (a job was queued for it), or cancel_notice(id).
inline constexpr std::string_view kJobsChannel = "skinspec_jobs";
// job_event_json: a job's progress as its bench publishes it.
inline constexpr std::string_view kJobEventsChannel = "skinspec_job_events";

std::string cancel_notice(store::Id job_id);
std::optional<store::Id> parse_cancel_notice(std::string_view text);

struct JobEvent {
  std::string bench;
  store::Id job_id = 0;
  std::optional<api::JobProgress> progress;  // nullopt: the job ended (its record says how)
};
std::string job_event_json(const JobEvent& event);
std::optional<JobEvent> parse_job_event(std::string_view text);

}  // namespace skinspec::daemon
