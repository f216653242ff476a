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
#include "measure_policy.hpp"

namespace skinspec::daemon {

class Supervisor final : public api::Acquisition {
 public:
  Supervisor(std::string device, store::Store& db, const Fitter& fitter, std::string version);
  ~Supervisor() override;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // What jobs do with rejected readings and old or changed whites; before start().
  void set_policy(const MeasurePolicy& policy) { policy_ = policy; }

  // Starts the worker thread; stop() cancels the running job, marks queued ones cancelled and
  // joins it.
  void start();
  void stop();

  nlohmann::json instrument_status() const override;
  std::expected<store::CreatedJob, api::ApiError> submit(store::Id session_id, const api::MeasureRequest& request,
                                                         const std::string& idempotency_key) override;
  std::expected<store::Job, api::ApiError> cancel(store::Id job_id) override;

 private:
  struct Outcome {
    store::JobState state = store::JobState::succeeded;
    std::string error;
    nlohmann::json result = nlohmann::json::object();
  };
  // The good readings of one job, and what was rejected on the way (supervisor_measure.cpp).
  struct Readings {
    std::vector<drivers::Reading> good;
    std::vector<store::Id> rejected_ids;
    std::vector<std::string> warnings;
    std::chrono::system_clock::time_point last_reply_at;  // when the meter's last reply was in
  };
  void run();
  Outcome execute(const store::Job& job, const api::MeasureRequest& request);
  std::expected<Readings, Outcome> take_readings(const store::Job& job, const api::MeasureRequest& request, drivers::Pr650& meter);
  std::expected<store::Id, Outcome> keep_rejected(const store::Job& job, int attempt, const drivers::InstrumentError& error);
  std::optional<Outcome> derive_sample(const store::Session& session, const store::Measurement& white, store::Measurement& m,
                                       std::optional<store::Fit>& fit, nlohmann::json& timing) const;
  std::optional<drivers::InstrumentError> ensure_connected();
  void note_instrument_error(const drivers::InstrumentError& error);
  void set_state(std::string state);

  const std::string device_;
  store::Store& db_;
  const Fitter& fitter_;
  const std::string version_;
  MeasurePolicy policy_;

  mutable std::mutex mutex_;  // guards everything below

  // The job queue (supervisor.cpp).
  std::condition_variable wake_;
  std::deque<std::pair<store::Id, api::MeasureRequest>> queue_;
  std::optional<store::Id> running_;
  bool cancel_running_ = false;
  bool stopping_ = false;
  std::thread worker_;

  // The instrument (supervisor_connection.cpp).
  std::string state_ = "disconnected";
  std::string last_error_;
  std::string serial_number_;
  std::optional<store::Id> instrument_id_;
  std::shared_ptr<drivers::Pr650> meter_;
};

}  // namespace skinspec::daemon
