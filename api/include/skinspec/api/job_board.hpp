#pragma once
// The one place where this program's queued and running jobs live, of every kind: their queues,
// places and progress, the count of changes their followers wait on, the protocol by which a job
// is cancelled (a queued one withdrawn, a running one asked to stop at its next step) and the
// jobs an Idempotency-Key names. The executors that run jobs (the daemon's measurements,
// FitJobs' imports and refits) write their records to the store and tell the board what
// happened; the router and the benches read it as a JobWatch.
//
// Locking: one mutex guards everything here. It is held for the board's own bookkeeping only,
// never across a store call, a meter's exchange or a call out of the board, so that it is
// always the last lock taken: a caller may hold a lock of its own while it calls the board.

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <expected>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/job_watch.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api {

// The queues. Each lane runs one job at a time, in the order of the jobs' ids, on a worker of
// its own: one measurement on the wire at a time, and one import or refit at a time (each
// spreads its fits over every core); a measurement never waits for an import.
enum class JobLane { instrument, fitting };
JobLane lane_of(JobKind kind);

// A running job's time left, counted down at every look rather than only when a step ends: the
// current step's deadline, then `steps_after` more steps of `per_step` each.
struct Countdown {
  std::chrono::steady_clock::time_point step_ends;
  std::chrono::milliseconds per_step{0};
  int steps_after = 0;
};

// The error a job asked to stop ends with: `cancelled` by request or `stopped` by the service.
store::JobError stop_error(store::JobErrorCode why);

// The answer to a job posted once its lane is closed (503).
ApiError service_stopping();

class JobBoard final : public JobWatch {
 public:
  JobBoard() = default;
  JobBoard(const JobBoard&) = delete;
  JobBoard& operator=(const JobBoard&) = delete;

  // ---- Idempotency --------------------------------------------------------------------------

  // The job `key` names already (nullopt: none, or no key), for a new job of `kind` to return
  // instead of being made again; a key naming a job of another kind is a conflict.
  static std::expected<std::optional<store::CreatedJob>, ApiError> earlier_job(const store::Store& db, JobKind kind,
                                                                               const std::string& key);

  // ---- Queues -------------------------------------------------------------------------------

  // Queues job `id` in `lane` at its place by id, with `initial` progress (its position is the
  // board's to count); false when the lane is closed or the job is here already.
  bool enqueue(JobLane lane, store::Id id, const JobProgress& initial = {});
  // Whether `lane` has been closed: it takes no more jobs.
  bool closed(JobLane lane) const;
  // Waits for the next job of `lane` and makes it the lane's running job, shown queued and
  // first until it reports; nullopt once the lane is closed.
  std::optional<store::Id> take_next(JobLane lane);
  // Takes queued job `id` off its queue; false when it is not queued here. It is shown as it
  // was until end().
  bool withdraw(store::Id id);
  // Asks running job `id` to stop at its next step, for `why` (cancelled or stopped; the first
  // reason asked for stays); false when it is not running here.
  bool ask_to_stop(store::Id id, store::JobErrorCode why);
  // Why running job `id` was asked to stop; nullopt: it goes on.
  std::optional<store::JobErrorCode> stop_asked(store::Id id) const;
  // Closes `lane`: nothing more is queued in it or taken from it, its running job is asked to
  // stop (stopped, whatever was asked before), and its queued jobs are withdrawn and returned in
  // order, for their executor to end their records.
  std::vector<store::Id> close(JobLane lane);

  struct LaneLoad {
    std::optional<store::Id> running;
    std::size_t queued = 0;
  };
  LaneLoad load(JobLane lane) const;
  // Whether job `id` is queued or running here, or was and its end could not be recorded.
  bool knows(store::Id id) const;

  // ---- Progress (each after the job's record was written) -----------------------------------

  // Job `id`'s progress now; why it should stop, if it should.
  std::optional<store::JobErrorCode> report(store::Id id, const JobProgress& progress);
  // Its phase and readings, the rest of its progress kept; a countdown of another phase ends.
  std::optional<store::JobErrorCode> report_phase(store::Id id, JobPhase phase, int readings_done);
  // Its time left counts down from `countdown` until it reports another phase.
  void start_countdown(store::Id id, const Countdown& countdown);
  // Job `id` is no longer queued or running here (its record says how it ended) and its lane
  // is free for the next. With `unrecorded`, the store refused its end: it is shown failed
  // with that error meanwhile.
  void end(store::Id id, std::optional<store::JobError> unrecorded = std::nullopt);
  // The jobs ended with `unrecorded`, and what they are shown: their records are still queued or
  // running, to be ended once the database takes writes again (end(id) then forgets them).
  std::vector<std::pair<store::Id, store::JobError>> unrecorded_ends() const;

  // ---- Other programs' jobs (docs/store.md, "Benches") --------------------------------------

  // Another program's job as it published it; nullopt: it ended.
  void note_remote(store::Id id, std::optional<JobProgress> progress);
  std::vector<store::Id> remote_jobs() const;
  // Keeps the ids of `lane`'s jobs that end, for take_lane_jobs() to hand out.
  void track_ends(JobLane lane);
  struct LaneJobs {
    std::map<store::Id, JobProgress> live;  // queued and running, with their positions
    std::vector<store::Id> ended;           // since the last call (with track_ends)
  };
  LaneJobs take_lane_jobs(JobLane lane);

  // ---- JobWatch -----------------------------------------------------------------------------

  std::optional<JobProgress> progress(store::Id job_id) const override;
  std::uint64_t changes() const override;
  std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                const std::atomic<bool>& abandoned) const override;
  void wake_waiters() const override;

 private:
  struct Entry {
    JobLane lane = JobLane::instrument;
    JobProgress progress;
    std::optional<Countdown> countdown;
  };
  struct Lane {
    std::deque<store::Id> queue;  // by id
    std::optional<store::Id> running;
    std::optional<store::JobErrorCode> stop_asked;  // of the running job
    bool closed = false;
    bool tracks_ends = false;
    std::vector<store::Id> ended;
  };

  // The rest are called with mutex_ held.
  Lane& lane(JobLane which) { return lanes_[static_cast<std::size_t>(which)]; }
  const Lane& lane(JobLane which) const { return lanes_[static_cast<std::size_t>(which)]; }
  // The lane job `id` runs in, when it is its running job.
  Lane* running_lane(store::Id id);
  const Lane* running_lane(store::Id id) const;
  std::optional<store::JobErrorCode> why_stop(store::Id id) const;
  // A job's progress replaced: a countdown of another phase ends.
  void set_progress(Entry& entry, const JobProgress& progress);
  // A job's progress as shown: its place in its queue, its time left counted down.
  JobProgress shown(store::Id id, const Entry& entry) const;
  // Counts a change and wakes the followers.
  void changed();

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // any job's change, for followers
  std::condition_variable queued_;           // a job queued or a lane closed, for the workers
  std::array<Lane, 2> lanes_;
  std::map<store::Id, Entry> live_;          // this program's queued and running jobs
  std::map<store::Id, JobProgress> remote_;  // other programs' jobs, as they publish them
  std::uint64_t changes_ = 0;
};

}  // namespace skinspec::api
