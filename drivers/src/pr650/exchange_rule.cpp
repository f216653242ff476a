#include "skinspec/drivers/pr650_exchange.hpp"

#include <algorithm>

namespace skinspec::drivers::pr650 {

namespace {

using std::chrono::milliseconds;

// The longest replies of each shape: a spectral report with a two-line header, and a generous
// line (the longest the meter sends, report 6, has 40 bytes).
constexpr std::size_t kSpectralReplyBytes = 1734;
constexpr std::size_t kLineReplyBytes = 64;
// One data line of a spectral report: a pause of two lines' time on a slow line is no gap.
constexpr std::size_t kDataLineBytes = 17;

milliseconds transfer_time(std::size_t bytes, const ReplyTiming& timing) {
  if (!(timing.line_bytes_per_second > 0)) return milliseconds::zero();
  return milliseconds(static_cast<long>(1000.0 * static_cast<double>(bytes) / timing.line_bytes_per_second));
}

std::size_t longest_reply(ReplyShape shape) {
  return shape == ReplyShape::spectral ? kSpectralReplyBytes : kLineReplyBytes;
}

// The pauses and length any reply of this shape may have on this line.
ExchangeRule streaming(ReplyShape shape, milliseconds first_byte, LostReply on_lost, const ReplyTiming& timing) {
  ExchangeRule rule;
  rule.shape = shape;
  rule.first_byte = first_byte;
  rule.idle = std::max(timing.idle, transfer_time(2 * kDataLineBytes, timing));
  rule.whole = rule.idle + 2 * transfer_time(longest_reply(shape), timing);
  rule.on_lost = on_lost;
  return rule;
}

}  // namespace

milliseconds measurement_time(int integration_ms, int averages, const ReplyTiming& timing) {
  const milliseconds per_average = integration_ms > 0 ? milliseconds(2L * integration_ms) : timing.adaptive_allowance;
  return per_average * std::max(averages, 1) + timing.measurement_overhead;
}

ExchangeRule exchange_rule(const Command& command, const ReplyTiming& timing) {
  switch (command.kind) {
    case CommandKind::contact:
      return streaming(ReplyShape::line, timing.contact, LostReply::give_up, timing);
    case CommandKind::setup:
      return streaming(ReplyShape::line, timing.reply, LostReply::ask_again, timing);
    // F measures the light's flicker (about a second) before it answers; asking again measures
    // it again, which changes nothing but the frequency a later setup may sync to.
    case CommandKind::flicker:
      return streaming(ReplyShape::line, timing.reply + timing.measurement_overhead, LostReply::ask_again, timing);
    case CommandKind::measure:
      return streaming(reply_shape_of_measure(command.code),
                       measurement_time(command.integration_ms, command.averages, timing), LostReply::measure_again,
                       timing);
    // A report is sized to its length: the meter formats all of it before the first byte, and
    // a spectral report's 1734 bytes take 1.8 s at 9600 baud. A fixed 0.5 s, as the field's
    // drivers give every reply, failed d5 under load.
    case CommandKind::report: {
      const ReplyShape shape = reply_shape_of_report(command.code);
      return streaming(shape, timing.reply + transfer_time(longest_reply(shape), timing), LostReply::ask_again, timing);
    }
  }
  return streaming(ReplyShape::line, timing.reply, LostReply::give_up, timing);
}

ExchangeRule second_try(ExchangeRule rule) {
  rule.first_byte *= 2;
  return rule;
}

}  // namespace skinspec::drivers::pr650
