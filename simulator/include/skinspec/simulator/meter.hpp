#pragma once
// A Photo Research meter (the PR-650 or a newer model, MeterOptions::model) as a byte-level
// state machine, serving one client at a time over any Transport.
//
// The meter has the state of a real one (docs/simulator.md): on the PR-650 the power-on window
// (remote if a command arrives within boot_window_s of power-on, silent otherwise until
// power_cycle()), on the newer models local mode until PHOTO and again after Q; echo mode after
// E, the setup of the last valid S, the buffer of the last measurement that D reports print,
// and its timing: measurements as long as their integration times, replies paced at 9600 baud,
// everything multiplied by time_scale (0: no waiting at all).
//
// Its readings come either from scenes (synthesis: one scene per successful measurement, the
// last one repeating) or from a recording it replays byte for byte.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/drivers/transport.hpp"
#include "skinspec/simulator/faults.hpp"
#include "skinspec/simulator/recording.hpp"
#include "skinspec/simulator/scenes.hpp"

namespace skinspec::simulator {

// How the detector responds to light, which decides integration times and quality codes.
struct SensorModel {
  // Peak spectral radiance (W/(sr m2 nm)) times integration time (ms) that fills the detector.
  double full_scale = 1.5;
  double adaptive_target = 0.8;  // adaptive integration aims at this fraction of full scale
  double low_light = 0.1;        // peak signal below this fraction of full scale: quality 18
  double weak_light = 0.01;      // below this: quality 10
  double overhead_ms = 300;      // per measurement, beyond a dark and a light integration per average
  double reply_ms = 20;          // thinking time before any other reply
  double flicker_ms = 1000;      // F: measuring the flicker
};

// How a newer model's replies differ from its profile's WireStyle (docs/simulator.md), to try
// what other firmware prints.
struct WireOverrides {
  std::optional<drivers::BannerEnd> banner;
  std::optional<int> status_digits;    // of data statuses: 4 or 5
  std::optional<bool> padded_errors;   // "-0008" rather than "-8"
  std::optional<int> exponent_digits;  // of the spectral data lines: 2 or 3
  std::string d111;                    // what D111 reports; empty: the profile's
  bool d120_manual = false;            // D120 prints the manuals' example (201 points by 2 nm)
};

struct MeterOptions {
  drivers::Model model = drivers::Model::pr650;
  WireOverrides wire;  // newer models only
  // Newer models: the firmware generation played (MeterProfile::firmware, by id: "m730");
  // empty: the model's newest.
  std::string firmware;
  bool trace_bytes = false;          // log every byte received, with the line it adds to
  double boot_window_s = 5;          // real seconds, not scaled
  double time_scale = 1;             // multiplies measurement times, reply delays and byte pacing
  std::string serial_number;         // D110; empty: the profile's ("60912345" for the PR-650)
  drivers::pr650::ReplyStyle style;  // PR-650: header H1 or H2, exponent 'E' or 'e'
  double noise = 0;                  // relative standard deviation of each spectral value (per average)
  std::uint64_t seed = 1;            // noise and the bytes of garbage and bit-flip faults
  bool stale_on_low_light = true;    // on quality 10 and 18 the data lines stay those of before
  bool m0_reports_quality = false;   // M0 prints "0qq" rather than always "000"
  SensorModel sensor;
  FaultPlan faults;
  // Replay: match each command with the next recorded one (in_order), or with the first unused
  // recorded exchange of the same command (by_command), for clients that order reports differently.
  enum class ReplayOrder { in_order, by_command } replay_order = ReplayOrder::in_order;
  // One line per event: faults that fired, measurements, replay mismatches, unknown commands,
  // mode changes. Called from the thread running serve() (or power_cycle()'s) with the meter
  // locked: it must not call back into the meter.
  std::function<void(std::string_view)> log;
};

// Synthesis: the meter measures these scenes, computing colour values with the observer.
struct Synthesis {
  Observer observer;
  std::vector<Scene> scenes;  // in measurement order; none: the meter looks at darkness
};

using ReadingSource = std::variant<Synthesis, Recording>;

class SimulatedMeter {
 public:
  enum class Mode {
    boot,    // PR-650: powered on, waiting for a first command within the window
    remote,  // answering commands
    local,   // PR-650: missed the window, or rebooted: silent until power_cycle();
             // newer models: listening for PHOTO only
  };
  enum class ServeEnd {
    stopped,       // `stop` was set, or the link was interrupted
    closed,        // the client went away
    disconnected,  // a disconnect fault closed the link
  };

  // Powered on now.
  SimulatedMeter(ReadingSource source, MeterOptions options = {});
  ~SimulatedMeter();
  SimulatedMeter(const SimulatedMeter&) = delete;
  SimulatedMeter& operator=(const SimulatedMeter&) = delete;

  // Serves one client until `stop` is set (checked at least every 20 ms), the link is
  // interrupted or closed, or a disconnect fault closes it. The meter's state carries over to
  // the next call, as a real meter's does when its cable is plugged in again. One call at a time.
  ServeEnd serve(drivers::Transport& link, const std::atomic<bool>& stop);

  // Switches the meter off and on: back to the power-on window (newer models: local mode),
  // echo off, setup and buffer cleared. The scene under the meter stays. Safe from any thread.
  void power_cycle();

  Mode mode() const;
  // Commands received, measurements made (including failed ones).
  std::size_t commands() const;
  std::size_t measurements() const;
  // Replay mismatches and commands the meter did not know, in order.
  std::vector<std::string> problems() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

std::string_view to_string(SimulatedMeter::Mode mode);
std::string_view to_string(SimulatedMeter::ServeEnd end);

}  // namespace skinspec::simulator
