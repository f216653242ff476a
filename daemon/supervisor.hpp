#pragma once
// The instrument supervisor: owns the one meter named by --device, connects when a job first
// needs it and again after it was lost, and runs measurement jobs one at a time from a FIFO
// queue (one measurement on the wire at a time). White readings are stored as the session's
// white reference; samples become reflectance against the latest white and are fitted, the
// reading, reflectance and fit stored in one transaction with the job's end, so that a
// stored measurement always belongs to a succeeded job. In the background it connects at
// start, notices a meter that went away (a periodic check while idle, USB hot-plug), and
// reconnects with backoff (docs/architecture.md, "The instrument connection").

#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"
#include "instrument_link.hpp"
#include "reconnect.hpp"
#include "measure_policy.hpp"
#include "meter_settings.hpp"

namespace skinspec::daemon {

class Supervisor final : public api::Acquisition {
 public:
  // `model`: the meter --model names, or auto (found out when connecting).
  Supervisor(std::string device, store::Store& db, const Fitter& fitter, drivers::ModelChoice model = {});
  ~Supervisor() override;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // What jobs do with rejected readings and old or changed whites; before start().
  void set_policy(const MeasurePolicy& policy) { policy_ = policy; }

  // Starts the worker thread; stop() cancels the running job, marks queued ones cancelled, joins
  // it and the connector, and disconnects the meter (which leaves remote mode: Q).
  void start();
  void stop();

  // ---- Benches (supervisor_benches.cpp; docs/store.md, "Benches") ----

  // This bench's name, and whether sessions of other benches are theirs to measure in (several
  // programs on one PostgreSQL database) rather than this one's (a SQLite file). Before start().
  void set_bench(std::string name, bool routes);
  // A job another program queued for this bench: queued here, in id order, unless known already.
  void adopt(const store::Job& job);
  // Another bench's job as its owner published it: its progress, or nullopt once it ended.
  void note_remote(store::Id job_id, std::optional<api::JobProgress> progress);
  // This bench's queued and running jobs with their positions and progress, and those that
  // ended since the last call, to publish.
  struct LocalJobs {
    std::map<store::Id, api::JobProgress> live;
    std::vector<store::Id> ended;
  };
  LocalJobs local_jobs();
  // Other benches' jobs shown live here.
  std::vector<store::Id> remote_jobs() const;
  // A cancel asked for through another program, of a job this one may be running.
  void cancel_here(store::Id job_id);

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
  // A step of a job: its value, or the error the job ends with.
  template <typename T>
  using Step = std::expected<T, store::JobError>;
  struct QueuedJob {
    store::Id id = 0;
    api::MeasureRequest request;
  };
  // The good readings of one job, and what was rejected on the way (supervisor_measure.cpp).
  struct Readings {
    std::vector<drivers::Reading> good;
    std::vector<store::Id> rejected_ids;
    std::vector<std::string> warnings;
    std::chrono::system_clock::time_point last_reply_at;  // when the meter's last reply was in
  };
  void run();
  bool owned_elsewhere(const store::Session& session) const;
  std::expected<store::CreatedJob, api::ApiError> submit_elsewhere(const store::Session& session, store::Job job);
  std::expected<store::Job, api::ApiError> cancel_elsewhere(const store::Job& job);
  bool known_here(store::Id job_id) const;  // mutex_ held
  // A job's live progress with its place in the queue (1 is next; 0 once it runs), mutex_ held.
  api::JobProgress with_position(store::Id job_id, api::JobProgress live) const;
  // The next job, marked running; nullopt when stopping. A job whose record cannot be marked
  // running comes with the error it ends with.
  std::optional<std::pair<QueuedJob, Step<store::Job>>> take_next();
  static std::pair<QueuedJob, Step<store::Job>> started(const QueuedJob& next, store::Result<store::Job> job);
  // Runs a job to its end; a job that succeeds is stored succeeded with its measurement. What
  // a job that fails got done (readings, rejected readings) goes to `partial`.
  Step<store::CompletedJob> execute(const store::Job& job, const api::MeasureRequest& request, nlohmann::json& partial);
  Step<void> take_readings(const store::Job& job, const api::MeasureRequest& request,
                           std::shared_ptr<drivers::Instrument>& meter, Readings& out);
  Step<store::Id> keep_rejected(const store::Job& job, int attempt, const drivers::InstrumentError& error);
  Step<std::optional<store::Fit>> derive_sample(const store::Session& session, const store::Measurement& white,
                                                store::Measurement& m, nlohmann::json& timing) const;
  Step<store::CompletedJob> store_measurement(const store::Job& job, const store::Measurement& m,
                                              const std::optional<store::Fit>& fit, const nlohmann::json& result);
  // Stores the end of a job that did not succeed and lets its followers know; a job cancelled
  // meanwhile ends cancelled whatever stopped it.
  void finish(store::Id id, const Step<store::CompletedJob>& outcome, const nlohmann::json& partial);
  // Writes a failed or cancelled job's end (and its result, when given), asking again after a
  // refusal that may pass; the store's error when it still refuses.
  std::optional<store::StoreError> record_end(store::Id id, const store::JobError& error,
                                              std::optional<std::string> result);
  // Whether the running job was asked to stop, and why (cancelled or stopped), with mutex_ held.
  bool cancel_requested() const { return cancel_running_.has_value(); }
  std::optional<drivers::InstrumentError> ensure_connected();
  std::expected<drivers::Reading, drivers::InstrumentError> measure_reading(std::shared_ptr<drivers::Instrument>& meter,
                                                                            const drivers::MeasureOptions& options,
                                                                            bool first_of_job);
  void note_instrument_error(const drivers::InstrumentError& error);
  MeterSettings meter_settings() const;
  MeterSettings known_settings() const;  // mutex_ held
  // The running job's phase and readings so far, told to its followers.
  void report_progress(api::JobPhase phase, int readings_done);
  // A reading starts that may take `reading_time` at most, with `after` more to come: the
  // running job's time left counts down from there (mutex_ not held).
  void start_reading_clock(std::chrono::milliseconds reading_time, int after);
  // What the driver found the meter's firmware to lack, onto the instrument's warnings, once.
  void note_firmware_warnings(const std::vector<std::string>& warnings);
  // With mutex_ held, after the job's store record was written: counts a change and wakes the
  // followers.
  void job_changed();
  // With mutex_ held: a job no longer queued or running here (its record says how it ended).
  void forget_live(store::Id id);

  const std::string device_;
  const drivers::ModelChoice model_;
  store::Store& db_;
  const Fitter& fitter_;
  MeasurePolicy policy_;

  mutable std::mutex mutex_;  // guards everything below

  // The job queue (supervisor.cpp).
  std::condition_variable wake_;
  std::deque<QueuedJob> queue_;
  std::optional<store::Id> running_;
  std::optional<store::JobErrorCode> cancel_running_;  // cancelled (by request) or stopped
  // The running job's time left while it measures: the current reading's deadline, each
  // command's own (drivers::Instrument::reading_time), and the readings after it.
  struct TimeLeft {
    std::chrono::steady_clock::time_point reading_ends;
    std::chrono::milliseconds per_reading{0};
    int readings_after = 0;
  };
  std::optional<TimeLeft> time_left_;
  bool stopping_ = false;
  std::thread worker_;

  // Progress of the queued and running jobs (and of those whose end the store refused), and
  // the change count their followers wait on.
  std::map<store::Id, api::JobProgress> live_;
  std::map<store::Id, api::JobProgress> remote_;  // other benches' jobs, as they publish them
  std::vector<store::Id> ended_;                  // this bench's jobs ended since local_jobs()
  std::string bench_;
  bool routes_ = false;
  std::uint64_t changes_ = 0;
  mutable std::condition_variable changed_;

  // The instrument (supervisor_connection.cpp).

  // The state and when it last changed; any assignment of another state restarts the clock.
  class TrackedState {
   public:
    TrackedState& operator=(api::InstrumentState state) {
      if (state != state_) {
        state_ = state;
        since_ = std::chrono::system_clock::now();
      }
      return *this;
    }
    bool operator==(api::InstrumentState state) const { return state_ == state; }
    api::InstrumentState value() const { return state_; }
    std::chrono::system_clock::time_point since() const { return since_; }

   private:
    api::InstrumentState state_ = api::InstrumentState::disconnected;
    std::chrono::system_clock::time_point since_ = std::chrono::system_clock::now();
  };

  TrackedState state_;
  std::string last_error_;
  std::optional<drivers::Identity> identity_;  // of the last meter reached
  // The apertures it lists (D117), kept with its identity; nullopt until read.
  std::optional<std::vector<std::string>> apertures_;
  // With --model auto, the model the last contact identified: tried first when connecting again,
  // since the meter on the port is most likely the same, and probing every family of a meter
  // that stays silent takes half a minute. Forgotten after a failed attempt, so the next one
  // identifies afresh (another meter may have been plugged in).
  std::optional<drivers::Model> expected_model_;
  std::optional<store::Id> instrument_id_;
  std::shared_ptr<drivers::Instrument> meter_;

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
  void check_holding_wire(const std::shared_ptr<drivers::Instrument>& meter);
  void lose_meter(const std::string& error);  // with mutex_ held
  // "the PR-670 on tcp:...": the meter as it said it is, for messages (mutex_ held).
  std::string meter_on_port() const;
  // The connector stopped and the meter disconnected, at a known point of stop().
  void release_meter();
  void note_connect_failure(const drivers::InstrumentError& error, const std::string& port);
  void note_connected(const std::shared_ptr<drivers::Instrument>& meter, const ResolvedDevice& resolved,
                      const drivers::Identity& identity, std::vector<std::string> apertures);
  api::InstrumentState unreachable_state() const {
    return ever_connected_ ? api::InstrumentState::lost : api::InstrumentState::disconnected;
  }

  ConnectionSettings link_;
  // Held by whoever connects, checks or (through ensure_connected) is about to measure, so that
  // only one of them owns the meter; always taken before mutex_, never while holding it.
  std::mutex wire_mutex_;
  std::string port_;                    // the concrete URI of the last connection
  std::optional<UsbIdentity> adapter_;  // the USB adapter of that connection
  bool ever_connected_ = false;         // "lost" rather than "disconnected" when unreachable
  int failed_attempts_ = 0;             // in a row, reset on success
  std::optional<std::chrono::steady_clock::time_point> next_attempt_;  // while unreachable
  std::chrono::steady_clock::time_point next_check_{};
  std::chrono::steady_clock::time_point next_hangup_look_{};
  // Last members: stopped and joined first when the supervisor is destroyed, while everything
  // they use is still alive (stop() has already told them to end).
  std::unique_ptr<drivers::HotplugMonitor> hotplug_;
  std::jthread connector_;
};

}  // namespace skinspec::daemon
