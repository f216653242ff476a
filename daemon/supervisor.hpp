#pragma once
// The instrument supervisor: owns the one meter named by --device, connects when a job first
// needs it and again after it was lost, and runs measurement jobs one at a time from a FIFO
// queue (one measurement on the wire at a time). White readings are stored as the session's
// white reference; samples become reflectance against the latest white and are fitted, the
// reading, reflectance and fit stored in one transaction.

#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::daemon {

class Supervisor final : public api::Acquisition {
 public:
  Supervisor(std::string device, store::Store& db, const Fitter& fitter, std::string version);
  ~Supervisor() override;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts the worker thread; stop() cancels the running job, marks queued ones cancelled and
  // joins it.
  void start();
  void stop();

  nlohmann::json instrument_status() const override;
  std::expected<store::CreatedJob, api::ApiError> submit(store::Id session_id, const api::MeasureRequest& request,
                                                         const std::string& idempotency_key) override;
  std::expected<store::Job, api::ApiError> cancel(store::Id job_id) override;
  std::optional<api::JobProgress> progress(store::Id job_id) const override;
  std::uint64_t changes() const override;
  std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                const std::atomic<bool>& abandoned) const override;
  void wake_waiters() const override;

 private:
  struct Outcome {
    store::JobState state = store::JobState::succeeded;
    std::string error;
    nlohmann::json result = nlohmann::json::object();
  };
  void run();
  Outcome execute(const store::Job& job, const api::MeasureRequest& request);
  std::optional<drivers::InstrumentError> ensure_connected();
  void note_instrument_error(const drivers::InstrumentError& error);
  void set_state(std::string state);
  // The running job's phase and readings so far, told to its followers.
  void report_progress(const char* phase, int readings_done);
  // With mutex_ held, after the job's store record was written: counts a change and wakes the
  // followers.
  void job_changed();

  const std::string device_;
  store::Store& db_;
  const Fitter& fitter_;
  const std::string version_;

  mutable std::mutex mutex_;  // guards everything below

  // The job queue (supervisor.cpp).
  std::condition_variable wake_;
  std::deque<std::pair<store::Id, api::MeasureRequest>> queue_;
  std::optional<store::Id> running_;
  bool cancel_running_ = false;
  bool stopping_ = false;
  std::thread worker_;

  // Progress of the queued and running jobs, and the change count their followers wait on.
  struct LiveJob {
    std::string phase = "queued";
    int readings_done = 0;
    int readings_total = 1;
  };
  std::map<store::Id, LiveJob> live_;
  std::uint64_t changes_ = 0;
  mutable std::condition_variable changed_;

  // The instrument (supervisor_connection.cpp).
  std::string state_ = "disconnected";
  std::string last_error_;
  std::string serial_number_;
  std::optional<store::Id> instrument_id_;
  std::shared_ptr<drivers::Pr650> meter_;
};

}  // namespace skinspec::daemon
