#pragma once
// The one meter named by --device: finding it (instrument_link.hpp), connecting and
// identifying, keeping it connected in the background (a periodic check while idle, USB
// hot-plug, reconnecting with backoff: reconnect.hpp), and what its state is. It runs no jobs:
// the measurement executor asks it for a connected meter and tells it what the meter did.
//
// Locking: mutex_ guards every member below it. It is never held across an exchange with the
// meter or a store call; the job board may be asked with it held (the board's lock is always
// the last). Two threads may want the meter: the measurement worker (ensure_connected, before
// it measures) and the connector (keep_connected); the MeterWire makes one of them its owner
// at a time, and the connector leaves the meter alone while a job is queued or running.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/store/store.hpp"
#include "instrument_link.hpp"
#include "meter_settings.hpp"
#include "reconnect.hpp"

namespace skinspec::daemon {

// Who may talk to the meter outside a measurement: whoever connects or checks it holds the
// wire. Locking: its one mutex is the wire itself, held across the exchange; it is taken before
// the ConnectionKeeper's mutex, never while holding it.
class MeterWire {
 public:
  [[nodiscard]] std::unique_lock<std::mutex> hold() { return std::unique_lock(mutex_); }

 private:
  std::mutex mutex_;
};

class ConnectionKeeper {
 public:
  struct Settings {
    BackoffPolicy backoff;
    // How often an idle connected meter is asked for its serial number, to notice that it went
    // away while nobody measured; 0: never.
    std::chrono::milliseconds check_interval{2000};
    DeviceResolver resolver = resolve_device;
    bool hotplug = true;  // watch USB adapters for usb: and auto devices
  };
  // `model`: the meter --model names, or auto (found out when connecting). `jobs_waiting`: whether
  // a measurement is queued or running, when the connector must leave the meter to it.
  ConnectionKeeper(std::string device, drivers::ModelChoice model, store::Store& db,
                   std::function<bool()> jobs_waiting);
  ~ConnectionKeeper();
  ConnectionKeeper(const ConnectionKeeper&) = delete;
  ConnectionKeeper& operator=(const ConnectionKeeper&) = delete;

  // Starts keeping the instrument connected in the background: call once. Without it, the
  // meter is connected only when a job needs it.
  void start(Settings settings);
  // No more connections; an exchange under way is cancelled and the connector told to end.
  void stop();
  // After stop(): the connector joined and the meter disconnected (which leaves remote mode: Q).
  void release_meter();
  // A USB adapter came or went: a reconnect attempt at once, or the instrument marked lost.
  void on_usb_event(const drivers::UsbDeviceEvent& event);

  // GET /api/v1/instrument but for the jobs: {"device", "port", "state", "since", "last_error",
  // "attempts", "next_attempt_in_ms", "capabilities", and the meter's identity}.
  nlohmann::json status() const;
  // What the identified meter takes, or before a meter was reached what the forced model takes
  // (any model with auto).
  MeterSettings settings() const;
  const std::string& device() const { return device_; }

  // ---- For the measurement executor ----

  // Connects unless connected; the error that prevented it.
  std::optional<drivers::InstrumentError> ensure_connected();
  // The connected meter to measure with, the state `measuring` meanwhile; null when it went
  // away (the hot-plug handler then has already marked it lost).
  std::shared_ptr<drivers::Instrument> begin_measuring();
  // Back from `measuring` (not over a `lost` set meanwhile).
  void end_measuring();
  // Cancels the meter's exchange under way, if any.
  void interrupt();
  void note_instrument_error(const drivers::InstrumentError& error);
  // What the driver found the meter's firmware to lack, onto the instrument's warnings, once.
  void note_firmware_warnings(const std::vector<std::string>& warnings);
  // The meter as the records name it: its family and its row in the store.
  struct MeterOfRecord {
    drivers::Family family = drivers::Family::pr650;
    std::optional<store::Id> instrument_id;
  };
  MeterOfRecord meter_of_record() const;

 private:
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

  void keep_connected();
  std::optional<std::chrono::steady_clock::time_point> next_link_action() const;  // mutex_ held
  void connect_or_check();
  std::optional<drivers::InstrumentError> connect_holding_wire();
  void check_holding_wire(const std::shared_ptr<drivers::Instrument>& meter);
  void lose_meter(const std::string& error);  // mutex_ held
  // "the PR-670 on tcp:...": the meter as it said it is, for messages (mutex_ held).
  std::string meter_on_port() const;
  MeterSettings known_settings() const;  // mutex_ held
  void note_connect_failure(const drivers::InstrumentError& error, const std::string& port);
  void note_connected(const std::shared_ptr<drivers::Instrument>& meter, const ResolvedDevice& resolved,
                      const drivers::Identity& identity, std::vector<std::string> apertures);
  api::InstrumentState unreachable_state() const {
    return ever_connected_ ? api::InstrumentState::lost : api::InstrumentState::disconnected;
  }

  const std::string device_;
  const drivers::ModelChoice model_;
  store::Store& db_;
  const std::function<bool()> jobs_waiting_;
  MeterWire wire_;

  mutable std::mutex mutex_;      // guards everything below
  std::condition_variable wake_;  // for the connector: something to do, or stopping
  bool stopping_ = false;
  Settings link_;
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
  std::string port_;                    // the concrete URI of the last connection
  std::optional<UsbIdentity> adapter_;  // the USB adapter of that connection
  bool ever_connected_ = false;         // "lost" rather than "disconnected" when unreachable
  int failed_attempts_ = 0;             // in a row, reset on success
  std::optional<std::chrono::steady_clock::time_point> next_attempt_;  // while unreachable
  std::chrono::steady_clock::time_point next_check_{};
  std::chrono::steady_clock::time_point next_hangup_look_{};

  // Last members: stopped and joined first when the keeper is destroyed, while everything they
  // use is still alive (stop() has already told them to end).
  std::unique_ptr<drivers::HotplugMonitor> hotplug_;
  std::jthread connector_;
};

}  // namespace skinspec::daemon
