#pragma once
// What the router needs from acquisition: the instrument's state, and a queue of measurement
// jobs. The daemon implements it with the drivers, the fitter and the store; the router knows
// only this interface, so that api/ does not depend on drivers/.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

#include <nlohmann/json.hpp>

#include "skinspec/api/errors.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api {

struct MeasureRequest {
  store::MeasurementKind kind = store::MeasurementKind::sample;
  int count = 1;  // readings averaged into one measurement (1-100)
  std::string label;
  int integration_ms = 0;  // 0: adaptive
};

// What the instrument is doing (GET /api/v1/instrument's "state").
enum class InstrumentState { disconnected, connecting, connected, measuring, lost };
std::string_view to_string(InstrumentState state);
std::optional<InstrumentState> parse_instrument_state(std::string_view text);
std::span<const std::pair<InstrumentState, std::string_view>> instrument_state_names();

// Where a job is, in order; `done` only finished jobs show.
enum class JobPhase { queued, connecting, measuring, fitting, storing, done };
std::string_view to_string(JobPhase phase);
std::optional<JobPhase> parse_job_phase(std::string_view text);
std::span<const std::pair<JobPhase, std::string_view>> job_phase_names();

// Where a queued or running job is.
struct JobProgress {
  int position = 1;  // in the FIFO queue while queued: 1 is next; ignored once it runs
  JobPhase phase = JobPhase::queued;
  int readings_done = 0;
  int readings_total = 1;
  // Set when the job has ended but the store refused its end: the job is shown failed with
  // this error (code `store`) instead of the record's state, which stays behind.
  std::optional<store::JobError> unrecorded_failure{};
};

class Acquisition {
 public:
  virtual ~Acquisition() = default;
  // {"device", "port", "state" (an InstrumentState), "since",
  //  "last_error", "serial_number", "attempts", "next_attempt_in_ms", "queued", ...}
  virtual nlohmann::json instrument_status() const = 0;
  // The serial ports and USB serial adapters present: {"ports": [...]} (GET /api/v1/ports).
  virtual nlohmann::json ports() const = 0;
  // Queues a measurement of an open session; an idempotency key seen before returns that job.
  virtual std::expected<store::CreatedJob, ApiError> submit(store::Id session_id, const MeasureRequest& request,
                                                            const std::string& idempotency_key) = 0;
  // Cancels a queued or running job; the job as it is afterwards.
  virtual std::expected<store::Job, ApiError> cancel(store::Id job_id) = 0;

  // The live progress of a queued or running job; nullopt once it has finished (its state is
  // in the store by then) or for a job this process does not run. Read it before the job's
  // record (current_job_json does): a job's record is written before its progress moves on.
  virtual std::optional<JobProgress> progress(store::Id job_id) const = 0;
  // A count that grows with every change of any job: position, phase, reading count, state.
  // The job's store record is written before the count grows.
  virtual std::uint64_t changes() const = 0;
  // Blocks until changes() exceeds `seen`, `timeout` passes, or `abandoned` is set and
  // wake_waiters() called; returns changes(). For followers of a job (Server-Sent Events).
  virtual std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                        const std::atomic<bool>& abandoned) const = 0;
  virtual void wake_waiters() const = 0;
};

// A time as every answer of the API shows it: RFC 3339, UTC, with microseconds.
std::string api_time(store::Time time);

// A job as the API shows it, with `position` (1 or more while queued, 0 while running, null
// once finished), `progress` and `error` ({code, message} or null): its live progress and
// state when given and the record has not finished, else what the store says (phase done,
// fraction 1 when it succeeded).
nlohmann::json job_json(const store::Job& job, const std::optional<JobProgress>& live);

// Job `id` as the API shows it now: its live progress read first, then its record, so that
// the two agree (`acquisition` may be null).
store::Result<nlohmann::json> current_job_json(const store::Store& db, const Acquisition* acquisition, store::Id id);

}  // namespace skinspec::api
