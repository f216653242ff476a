#pragma once
// How the driver waits for each of the PR-650's replies and what it does when one is lost or
// damaged, as data: one rule per command, a pure function of the command and the timing
// settings (docs/pr650-protocol.md, "Waiting for replies"). The driver follows the rules; tests
// read them.
//
// A reply is waited for in two stages. Its first byte must come within `first_byte` of the
// command (the meter's thinking time, or the measurement itself for M); after that the reply
// streams, and a pause longer than `idle` ends it as cut short. So a lost reply costs
// `first_byte` and a cut one `idle`, never the length of a measurement.

#include <chrono>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650 {

struct ReplyTiming {
  // First contact (B3), per attempt: a meter just switched on may be slow to answer.
  std::chrono::milliseconds contact{2000};
  // The first byte of a reply that needs no measurement (setup, reports). Drivers in the field
  // give the meter 0.5 s for these.
  std::chrono::milliseconds reply{500};
  // M and F: beyond the integration time (the meter's own work, which no source quantifies).
  std::chrono::milliseconds measurement_overhead{5000};
  // Adaptive integration chooses its own time: a dim patch can take 30 s per average.
  std::chrono::milliseconds adaptive_allowance{30000};
  // The longest pause inside a reply, at least. The meter streams a report without gaps (drivers
  // in the field end a reply at 50 ms of silence); the margin is for USB adapters and serial
  // servers.
  std::chrono::milliseconds idle{250};
  // The line rate in bytes per second (9600 baud, 8N1): a slower line gets longer pauses and
  // more time for a whole report.
  double line_bytes_per_second = 960;
};

enum class CommandKind {
  contact,  // B3, the first command of a connection
  setup,    // S
  flicker,  // F
  measure,  // M0 (M1-M6 likewise)
  report,   // D1-D6, D110, D120, D201
};

struct Command {
  CommandKind kind = CommandKind::report;
  int code = 0;            // the report's number, for M and D
  int integration_ms = 0;  // for M: 10-6000, or 0 = adaptive
  int averages = 1;        // for M
};

// What the driver does when a reply does not come, stops short, or cannot be read.
enum class LostReply {
  give_up,    // report it (first contact makes its own attempts)
  ask_again,  // send the same command once more: setup and reports change nothing on the meter
  // M: a reply that came but was damaged still says the meter measured, and the reports that
  // follow carry the measurement and its quality code; only a measurement that never answered
  // is made again, once, and the reading says so.
  measure_again,
};

struct ExchangeRule {
  ReplyShape shape = ReplyShape::line;
  std::chrono::milliseconds first_byte{0};  // from the command to the reply's first byte
  std::chrono::milliseconds idle{0};        // the longest pause inside the reply
  std::chrono::milliseconds whole{0};       // from the first byte to the last, at most
  LostReply on_lost = LostReply::give_up;
};

ExchangeRule exchange_rule(const Command& command, const ReplyTiming& timing);

// The rule for asking again: the same, with twice the wait for the first byte, so that a reply
// that was only late arrives during it.
ExchangeRule second_try(ExchangeRule rule);

// How long a measurement may take before its reply: a dark and a light integration per average
// (adaptive integration: the allowance), plus the overhead.
std::chrono::milliseconds measurement_time(int integration_ms, int averages, const ReplyTiming& timing);

}  // namespace skinspec::drivers::pr650
