#pragma once
// The instrument supervisor: owns the one meter named by --device, connects when a job first
// needs it and again after it was lost, and runs measurement jobs one at a time from a FIFO
// queue (one measurement on the wire at a time). White readings are stored as the session's
// white reference; samples become reflectance against the latest white and are fitted, the
// reading, reflectance and fit stored in one transaction. In the background it connects at
// start, notices a meter that went away (a periodic check while idle, USB hot-plug), and
// reconnects with backoff (docs/architecture.md, "The instrument connection").

#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"
#include "instrument_link.hpp"
#include "reconnect.hpp"
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
  // The good readings of one job, and what was rejected on the way (supervisor_measure.cpp).
  struct Readings {
    std::vector<drivers::Reading> good;
    std::vector<store::Id> rejected_ids;
    std::vector<std::string> warnings;
    std::chrono::system_clock::time_point last_reply_at;  // when the meter's last reply was in
  };
  void run();
  Outcome execute(const store::Job& job, const api::MeasureRequest& request);
  std::expected<Readings, Outcome> take_readings(const store::Job& job, const api::MeasureRequest& request,
                                                 std::shared_ptr<drivers::Pr650>& meter);
  std::expected<store::Id, Outcome> keep_rejected(const store::Job& job, int attempt, const drivers::InstrumentError& error);
  std::optional<Outcome> derive_sample(const store::Session& session, const store::Measurement& white, store::Measurement& m,
                                       std::optional<store::Fit>& fit, nlohmann::json& timing) const;
  std::optional<drivers::InstrumentError> ensure_connected();
  std::expected<drivers::Reading, drivers::InstrumentError> measure_reading(std::shared_ptr<drivers::Pr650>& meter,
                                                                            const drivers::MeasureOptions& options,
                                                                            bool first_of_job);
  void note_instrument_error(const drivers::InstrumentError& error);
  // The running job's phase and readings so far, told to its followers.
  void report_progress(const char* phase, int readings_done);
  // With mutex_ held, after the job's store record was written: counts a change and wakes the
  // followers.
  void job_changed();

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

  // The state's name and when it last changed; any assignment of another name restarts the clock.
  class TrackedState {
   public:
    TrackedState& operator=(const std::string& name) {
      if (name != name_) {
        name_ = name;
        since_ = std::chrono::system_clock::now();
      }
      return *this;
    }
    bool operator==(std::string_view name) const { return name_ == name; }
    const std::string& name() const { return name_; }
    std::chrono::system_clock::time_point since() const { return since_; }

   private:
    std::string name_ = "disconnected";
    std::chrono::system_clock::time_point since_ = std::chrono::system_clock::now();
  };

  TrackedState state_;
  std::string last_error_;
  std::string serial_number_;
  std::optional<store::Id> instrument_id_;
  std::shared_ptr<drivers::Pr650> meter_;

 public:
  struct ConnectionSettings {
    BackoffPolicy backoff;
    // How often an idle connected meter is asked for its serial number, to notice that it went
    // away while nobody measured; 0: never.
    std::chrono::milliseconds check_interval{2000};
    DeviceResolver resolver = resolve_device;
    bool hotplug = true;  // watch USB adapters for usb: and auto devices
  };
  // Starts keeping the instrument connected in the background: call once, before start().
  // Without it, the supervisor connects only when a job needs the meter.
  void start_connection(ConnectionSettings settings);
  // A USB adapter came or went: a reconnect attempt at once, or the instrument marked lost.
  void on_usb_event(const drivers::UsbDeviceEvent& event);
  nlohmann::json ports() const override;

 private:
  void keep_connected();
  std::optional<std::chrono::steady_clock::time_point> next_link_action() const;
  void connect_or_check();
  std::optional<drivers::InstrumentError> connect_holding_wire();
  void check_holding_wire(const std::shared_ptr<drivers::Pr650>& meter);
  void lose_meter(const std::string& error);  // with mutex_ held
  void note_connect_failure(const drivers::InstrumentError& error, const std::string& port);
  void note_connected(const std::shared_ptr<drivers::Pr650>& meter, const ResolvedDevice& resolved,
                      const std::string& serial_number);
  const char* unreachable_state() const { return ever_connected_ ? "lost" : "disconnected"; }

  ConnectionSettings link_;
  // Held by whoever connects, checks or (through ensure_connected) is about to measure, so that
  // only one of them owns the meter; always taken before mutex_, never while holding it.
  std::mutex wire_mutex_;
  std::string port_;                     // the concrete URI of the last connection
  std::optional<UsbIdentity> adapter_;   // the USB adapter of that connection
  bool ever_connected_ = false;          // "lost" rather than "disconnected" when unreachable
  int failed_attempts_ = 0;              // in a row, reset on success
  std::optional<std::chrono::steady_clock::time_point> next_attempt_;  // while unreachable
  std::chrono::steady_clock::time_point next_check_{};
  std::chrono::steady_clock::time_point next_hangup_look_{};
  // Last members: stopped and joined first when the supervisor is destroyed, while everything
  // they use is still alive (stop() has already told them to end).
  std::unique_ptr<drivers::HotplugMonitor> hotplug_;
  std::jthread connector_;
};

}  // namespace skinspec::daemon
