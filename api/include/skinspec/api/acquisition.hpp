#pragma once
// What the router needs from acquisition: the instrument's state, and a queue of measurement
// jobs. The daemon implements it with the drivers, the fitter and the store; the router knows
// only this interface, so that api/ does not depend on drivers/.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <expected>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "skinspec/api/errors.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api {

struct MeasureRequest {
  store::MeasurementKind kind = store::MeasurementKind::sample;
  int count = 1;            // readings averaged into one measurement (1-100)
  std::string label;
  int integration_ms = 0;   // 0: adaptive
};

// Where a queued or running job is. Phases in order: queued, connecting, measuring, fitting,
// storing (then done, which only finished jobs show).
struct JobProgress {
  int position = 1;  // in the FIFO queue: 1 is next, 0 is running
  std::string phase = "queued";
  int readings_done = 0;
  int readings_total = 1;
};

class Acquisition {
 public:
  virtual ~Acquisition() = default;
  // {"device", "port", "state": disconnected|connecting|connected|measuring|lost, "since",
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
  // in the store by then) or for a job this process does not run.
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

// The model the service fits with: the store keeps the paper's five parameters of a fit.
inline constexpr ModelKind kServiceModel = ModelKind::paper;

// A fit result as the store keeps it, with the options, program version and tables digest.
store::Fit stored_fit(const FitResult& result, const nlohmann::json& options, const std::string& model_version,
                      const std::string& tables_digest);

// A time as every answer of the API shows it: RFC 3339, UTC, with microseconds.
std::string api_time(store::Time time);

// A job as the API shows it, with `position` (null once finished) and `progress`: its live
// progress when given, else what the store says (phase done, fraction 1 when it succeeded).
nlohmann::json job_json(const store::Job& job, const std::optional<JobProgress>& live);

}  // namespace skinspec::api
