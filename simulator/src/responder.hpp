#pragma once
// What answers a command inside the simulated meter (private to simulator/): the synthetic
// instrument or a recording being replayed. The meter around it owns the wire: framing, the
// power-on window, echo, pacing and the faults that act on bytes.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/simulator/faults.hpp"
#include "skinspec/simulator/meter.hpp"
#include "skinspec/simulator/recording.hpp"

namespace skinspec::simulator::detail {

struct Command {
  std::string text;  // as received, upper case, without terminator
  std::string key;   // lower case: the letter and, for B, M and D, its code ("m0", "d110", "s")
  char letter = 0;   // upper case
  std::string_view parameters() const { return std::string_view(text).substr(1); }
};

Command parse_command(std::string_view line);

struct Reply {
  std::string bytes;
  double delay_ms = 0;  // before the first byte, at time scale 1
  double byte_interval_ms = kLineByteIntervalMs;
  bool echo_on = false;  // the command was E
};

struct Outcome {
  std::optional<Reply> reply;         // none: the meter says nothing
  std::vector<std::string> notes;     // for the log
  std::vector<std::string> problems;  // also kept by the meter (replay mismatches, unknown commands)
};

class Responder {
 public:
  virtual ~Responder() = default;
  // Answers a command. Faults on the meter's state (quality, stale) that it applies are removed
  // from `faults`; a replayed exchange adds its own.
  virtual Outcome respond(const Command& command, std::vector<Fault>& faults) = 0;
  // What the meter sends without being asked (a recording's exchanges without a command).
  virtual std::optional<Reply> unprompted() { return std::nullopt; }
  virtual void power_cycle() = 0;
  virtual std::size_t measurements() const = 0;
};

std::unique_ptr<Responder> make_instrument(Synthesis synthesis, const MeterOptions& options);
std::unique_ptr<Responder> make_replayer(Recording recording, const MeterOptions& options);

}  // namespace skinspec::simulator::detail
