#pragma once
// The executor of measurement jobs on the board's instrument lane: one at a time, in the order
// of their ids (one measurement on the wire at a time), on a worker thread of its own. White
// readings are stored as the session's white reference; samples become reflectance against the
// latest white and are fitted, the reading, reflectance and fit stored in one transaction with
// the job's end, so that a stored measurement always belongs to a succeeded job. The jobs'
// places, progress and cancel requests are the board's; the meter is the ConnectionKeeper's.
//
// Locking: submit_mutex_ is held from a job's record being made until it is on the board, so
// that this program's jobs queue in the order of their ids; nothing else is guarded by it, and
// the worker never takes it. The store and the board may be called with it held.

#include <expected>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/api/job_board.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"
#include "connection_keeper.hpp"
#include "measure_policy.hpp"

namespace skinspec::daemon {

class MeasurementExecutor {
 public:
  MeasurementExecutor(store::Store& db, const Fitter& fitter, api::JobBoard& board, ConnectionKeeper& keeper);
  ~MeasurementExecutor();
  MeasurementExecutor(const MeasurementExecutor&) = delete;
  MeasurementExecutor& operator=(const MeasurementExecutor&) = delete;

  // What jobs do with rejected readings and old or changed whites; before start().
  void set_policy(const MeasurePolicy& policy) { policy_ = policy; }
  // Starts the worker: call once.
  void start();
  // After the board's lane was closed: waits for the running job to end.
  void join();
  // Ends the records of jobs that never ran because the service stopped.
  void end_stopped(const std::vector<store::Id>& never_ran);

  // Makes job's record and queues it; `count` readings will be taken.
  std::expected<store::CreatedJob, api::ApiError> submit(const store::Job& job, int count);
  // Cancels job `id` when it is queued here: its record ended, the job as it is then; nullopt
  // when it is not queued here.
  std::optional<std::expected<store::Job, api::ApiError>> withdraw(store::Id id);
  // Asks job `id` to stop at its next step, and the meter's exchange under way to end, when it
  // runs here; whether it does.
  bool ask_to_stop(store::Id id);

 private:
  static constexpr auto kLane = api::JobLane::instrument;

  // A step of a job: its value, or the error the job ends with.
  template <typename T>
  using Step = std::expected<T, store::JobError>;
  // The good readings of one job, and what was rejected on the way (measurement_job.cpp).
  struct Readings {
    std::vector<drivers::Reading> good;
    std::vector<store::Id> rejected_ids;
    std::vector<std::string> warnings;
    std::chrono::system_clock::time_point last_reply_at;  // when the meter's last reply was in
  };

  void run();
  // Marks taken job `id` running: its record and request, or the error it ends with; nullopt
  // when it was cancelled through another program before it started.
  std::optional<Step<store::Job>> begin(store::Id id);
  // Runs a job to its end; a job that succeeds is stored succeeded with its measurement. What
  // a job that fails got done (readings, rejected readings) goes to `partial`.
  Step<store::CompletedJob> execute(const store::Job& job, nlohmann::json& partial);
  Step<store::CompletedJob> measure(const store::Job& job, const api::MeasureRequest& request, nlohmann::json& partial);
  Step<void> take_readings(const store::Job& job, const api::MeasureRequest& request,
                           std::shared_ptr<drivers::Instrument>& meter, Readings& out);
  // One reading; a job whose first command finds the link dead connects once more.
  std::expected<drivers::Reading, drivers::InstrumentError> measure_reading(store::Id job_id,
                                                                            std::shared_ptr<drivers::Instrument>& meter,
                                                                            const drivers::MeasureOptions& options,
                                                                            bool first_of_job);
  Step<store::Id> keep_rejected(const store::Job& job, int attempt, const drivers::InstrumentError& error);
  Step<std::optional<store::Fit>> derive_sample(const store::Session& session, const store::Measurement& white,
                                                store::Measurement& m, nlohmann::json& timing) const;
  Step<store::CompletedJob> store_measurement(const store::Job& job, const store::Measurement& m,
                                              const std::optional<store::Fit>& fit, const nlohmann::json& result);
  // Whether the running job was asked to stop: the error it then ends with.
  std::optional<store::JobError> stop_requested(store::Id id) const;
  // Job `id` as its record says it was stored, when it succeeded: by a commit whose connection
  // was lost before its answer came.
  std::optional<store::CompletedJob> stored_before_the_connection_was_lost(store::Id id) const;
  // Stores the end of a job that did not succeed and lets its followers know; a job cancelled
  // meanwhile ends cancelled whatever stopped it.
  void finish(store::Id id, const Step<store::CompletedJob>& outcome, const nlohmann::json& partial);
  // Writes a failed or cancelled job's end (and its result, when given), asking again after a
  // refusal that may pass; the store's error when it still refuses.
  std::optional<store::StoreError> record_end(store::Id id, const store::JobError& error,
                                              std::optional<std::string> result);

  store::Store& db_;
  const Fitter& fitter_;
  api::JobBoard& board_;
  ConnectionKeeper& keeper_;
  MeasurePolicy policy_;
  std::mutex submit_mutex_;
  std::thread worker_;
};

}  // namespace skinspec::daemon
