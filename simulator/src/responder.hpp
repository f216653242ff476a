#pragma once
// What answers a command inside the simulated meter (private to simulator/): the synthetic
// PR-650, the synthetic newer meter (PR-655 and later) or a recording being replayed. The meter
// around it owns the wire: framing, the power-on window or remote mode, echo, pacing and the
// faults that act on bytes.

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
  // Lower case: the letter and, for B, M and D, its code ("m0", "d110", "s"); on the newer
  // meters a setup's two letters ("se") and the keywords ("photo", "q").
  std::string key;
  char letter = 0;  // upper case
  std::string_view parameters() const { return std::string_view(text).substr(1); }
};

Command parse_command(std::string_view line);
// A frame of the newer meters' framer (a line, or the keywords PHOTO and Q).
Command parse_remote_command(std::string_view frame);

struct Reply {
  std::string bytes;
  double delay_ms = 0;  // before the first byte, at time scale 1
  double byte_interval_ms = kLineByteIntervalMs;
  std::optional<bool> echo;  // the command (E) turned echo on or off
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
  // A command the meter ignored by itself (PHOTO while already remote): a replay passes over
  // the recorded silence that answered it.
  virtual void skipped(const Command& /*command*/) {}
  virtual void power_cycle() = 0;
  virtual std::size_t measurements() const = 0;
};

std::unique_ptr<Responder> make_instrument(Synthesis synthesis, const MeterOptions& options);
// The newer meter named by options.model, from its MeterProfile.
std::unique_ptr<Responder> make_remote_instrument(Synthesis synthesis, const MeterOptions& options);
std::unique_ptr<Responder> make_replayer(Recording recording, const MeterOptions& options);

}  // namespace skinspec::simulator::detail
