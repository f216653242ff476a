#pragma once
// Faults the simulated PR-650 can be told to commit, and the small grammar that names them
// (docs/simulator.md):
//
//   SPEC    = COMMAND ":" FAULT [ "=" VALUE ] [ "@" N [ "+" ] ]
//   COMMAND = "*" | a command letter (b s f m d e; on the newer meters also i t p a v)
//           | a letter with its code ("m0", "d5", "d110") | a setup ("se", "ss", "sk", "sn", "sh",
//           "sf", "su") | a keyword of the newer meters ("photo", "q")
//
// "d5:truncate" truncates every D5 reply, "m0:no-answer@2" swallows only the second M0,
// "m:quality=18@3+" gives every measurement from the third on quality 18, "*:garbage" puts
// garbage into every reply. A recording's exchange carries faults without the COMMAND part.

#include <cstdint>
#include <expected>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::simulator {

enum class FaultKind {
  no_answer,   // the command is lost: no reply, no effect
  late,        // value: extra delay in ms of real time (not scaled), default 1000
  truncate,    // value: bytes kept, default half of the reply; then silence
  garbage,     // value: bytes of line noise inserted inside the reply, default 8
  bitflip,     // value: bits flipped at random places in the reply, default 1
  drop_line,   // value: the line left out (1-based), default a random data line
  line_count,  // value: data lines in a spectral report (fewer or more than 101); required
  disconnect,  // value: bytes sent before the link is closed, default half of the reply
  quality,     // value: the measurement's quality code 0-99; required
  stale,       // value: quality code, default 18; the measurement leaves the data lines alone
  reboot,      // the meter restarts: silent (local mode) until power_cycle()
  exponent,    // value: "e" or "E", the exponent letter of every value in the reply
  header,      // value: "h1" or "h2", the spectral report's header layout
  // Faults of the newer meters (PR-655 and later):
  fast_loss,  // value: ms; a byte arriving sooner than this after the one before is lost (on "*")
  glue,       // on photo: the banner is held back and sent in front of the next reply
  error,      // value: a negative status; the measurement (m, t) fails with it, a setup (s...) or
              // report (d...) is refused with it; required
  busy,       // value: extra "0001" answers of P before the measurement is done, default 1
};

std::string_view to_string(FaultKind kind);

struct Fault {
  FaultKind kind = FaultKind::no_answer;
  // The value, or negative when none was given (then the default above applies).
  double amount = -1;
  char exponent = 'e';                                                                 // for exponent
  drivers::pr650::HeaderVariant header = drivers::pr650::HeaderVariant::h2_two_lines;  // for header

  // "truncate=100", "exponent=e", "no-answer": the FAULT[=VALUE] part of a spec.
  std::string to_string() const;
};

// "FAULT[=VALUE]", as in a recording's "fault" field.
std::expected<Fault, std::string> parse_fault(std::string_view text);

struct FaultSpec {
  std::string command = "*";  // lower case: "*", "m", "d5", ...
  Fault fault;
  int at = 0;            // 0: every matching command; N: the Nth only
  bool onwards = false;  // with at: the Nth and every later one

  bool matches(std::string_view command_key) const;
  std::string to_string() const;
};

std::expected<FaultSpec, std::string> parse_fault_spec(std::string_view text);

// Which faults hit which command: the specs, each counting the commands it matches, and an
// optional seeded random mode that gives each command a fault with probability `rate`, except
// the `gap` commands after a random fault (gap 1 spares the command a client sends again after
// a fault: a soak of single faults). The random mode never chooses disconnect or reboot, which
// end a session; ask for those by spec.
class FaultPlan {
 public:
  FaultPlan() = default;
  explicit FaultPlan(std::vector<FaultSpec> specs, double random_rate = 0, std::uint64_t seed = 1, int gap = 0);

  // Parses every spec; the error names the spec at fault. The rate must lie in [0, 1], the gap
  // must not be negative.
  static std::expected<FaultPlan, std::string> parse(std::span<const std::string> specs, double random_rate = 0,
                                                     std::uint64_t seed = 1, int gap = 0);

  // The faults for the next command with this key ("m0", "d5", "s", ...), in spec order.
  std::vector<Fault> next(std::string_view command_key);

  const std::vector<FaultSpec>& specs() const { return specs_; }
  double random_rate() const { return random_rate_; }
  bool empty() const { return specs_.empty() && random_rate_ <= 0; }

 private:
  std::vector<FaultSpec> specs_;
  std::vector<int> seen_;  // per spec: matching commands so far
  double random_rate_ = 0;
  int gap_ = 0;
  int spared_ = 0;  // commands still spared after the last random fault
  std::mt19937_64 rng_;
};

}  // namespace skinspec::simulator
