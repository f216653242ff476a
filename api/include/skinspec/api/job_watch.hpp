#pragma once
// What the router needs from whatever runs jobs: each job's live place and progress, and a way
// to wait for the next change. The JobBoard (job_board.hpp) keeps them for every kind: the
// acquisition runs measurement jobs on it, FitJobs imports and refits.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <utility>

#include "skinspec/store/types.hpp"

namespace skinspec::api {

// What a job does, as its record's `kind` names it.
enum class JobKind {
  measure,  // a measurement with the instrument (POST /sessions/{id}/measurements)
  import,   // a file of spectra imported into a session (POST /sessions/{id}/imports)
  refit,    // stored measurements fitted again (POST /refits)
  map,      // every pixel of a spectral image fitted, the skin map stored (POST /maps)
};
std::string_view to_string(JobKind kind);
std::optional<JobKind> parse_job_kind(std::string_view text);
std::span<const std::pair<JobKind, std::string_view>> job_kind_names();

// Where a job is, in order; `done` only finished jobs show. A measurement goes queued,
// connecting, measuring, fitting, storing; an import queued, reading, fitting, storing; a refit
// queued, fitting (each batch stored as it is fitted); a map queued, reading, fitting, storing.
enum class JobPhase { queued, connecting, measuring, reading, fitting, storing, done };
std::string_view to_string(JobPhase phase);
std::optional<JobPhase> parse_job_phase(std::string_view text);
std::span<const std::pair<JobPhase, std::string_view>> job_phase_names();

// Where a queued or running job is.
struct JobProgress {
  int position = 1;  // in the FIFO queue while queued: 1 is next; ignored once it runs
  JobPhase phase = JobPhase::queued;
  int readings_done = 0;  // a measurement's readings
  int readings_total = 1;
  // Set when the job has ended but the store refused its end: the job is shown failed with
  // this error (code `store`) instead of the record's state, which stays behind.
  std::optional<store::JobError> unrecorded_failure{};
  // An import's or a refit's spectra (a map's pixels), and the seconds left at the rate so far
  // once known.
  std::int64_t spectra_done = 0;
  std::int64_t spectra_total = 0;
  std::optional<double> remaining_s{};
};

class JobWatch {
 public:
  virtual ~JobWatch() = default;
  // The live progress of a queued or running job; nullopt once it has finished (its state is
  // in the store by then) or for a job this process does not run. Read it before the job's
  // record (current_job_json does): a job's record is written before its progress moves on.
  virtual std::optional<JobProgress> progress(store::Id job_id) const = 0;
  // A count that grows with every change of any job: position, phase, progress, state.
  // The job's store record is written before the count grows.
  virtual std::uint64_t changes() const = 0;
  // Blocks until changes() exceeds `seen`, `timeout` passes, or `abandoned` is set and
  // wake_waiters() called; returns changes(). For followers of a job (Server-Sent Events).
  virtual std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                        const std::atomic<bool>& abandoned) const = 0;
  virtual void wake_waiters() const = 0;
};

}  // namespace skinspec::api
