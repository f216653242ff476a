// PR-7xx trigger, poll, abort and last-error exchanges (M740 and the PR-7XX manual).

#include "skinspec/drivers/pr7xx_protocol.hpp"

#include <fmt/format.h>

#include "pr6xx/fields.hpp"

namespace skinspec::drivers::pr7xx {

namespace {

using detail::fail;
using detail::quoted;
using Kind = ProtocolError::Kind;

constexpr int kMeasuring = 1;  // P while measuring; A with nothing to abort

bool only_noise(std::string_view reply) {
  for (const char c : reply) {
    if (!detail::is_line_end(c) && !detail::is_prompt_or_blank(c)) return false;
  }
  return true;
}

// "0000,<tail>": the tail's whole number, when it is one ("0000,-8").
std::optional<int> tail_code(std::string_view tail) {
  if (pr6xx::fields::match_status(tail) != detail::Match::full) return std::nullopt;
  return pr6xx::fields::status_value(tail).code;
}

}  // namespace

std::string format_trigger(const pr6xx::CommandStyle& style) { return pr6xx::format_command("T", style); }
std::string format_poll(const pr6xx::CommandStyle& style) { return pr6xx::format_command("P", style); }
std::string format_abort(const pr6xx::CommandStyle& style) { return pr6xx::format_command("A", style); }
std::string format_last_error(const pr6xx::CommandStyle& style) { return pr6xx::format_command("V", style); }

std::expected<std::optional<pr6xx::Status>, ProtocolError> parse_trigger(std::string_view reply) {
  if (only_noise(reply)) return std::optional<pr6xx::Status>();
  const auto status = pr6xx::parse_status(reply);
  if (!status) return std::unexpected(status.error());
  return std::optional<pr6xx::Status>(*status);
}

std::expected<PollReply, ProtocolError> parse_poll(std::string_view reply) {
  detail::LineSplitter lines(reply);
  const auto line = detail::first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  const auto leading = pr6xx::fields::leading_status(*line);
  if (!leading) return std::unexpected(leading.error());
  if (auto error = detail::check_end(*line, lines)) return std::unexpected(*error);
  const int code = leading->status.code;
  if (code == kMeasuring && !leading->rest) return PollReply{PollReply::State::measuring, std::nullopt, {}};
  if (code < 0) return PollReply{PollReply::State::done, code, {}};
  if (code != 0) return fail(Kind::garbled, line->number, "not a poll reply: " + quoted(line->text));
  const std::string_view tail = leading->rest.value_or("");
  if (!detail::is_printable(tail)) return fail(Kind::garbled, line->number, "a non-printable byte in " + quoted(tail));
  return PollReply{PollReply::State::done, tail_code(tail), std::string(tail)};
}

std::expected<AbortReply, ProtocolError> parse_abort(std::string_view reply) {
  const auto status = pr6xx::parse_status(reply);
  if (!status) return std::unexpected(status.error());
  switch (status->code) {
    case 0:
      return AbortReply{AbortReply::Result::aborted, 0};
    case kMeasuring:
      return AbortReply{AbortReply::Result::nothing_running, kMeasuring};
    default:
      if (status->code < 0) return AbortReply{AbortReply::Result::refused, status->code};
      return fail(Kind::garbled, 0, fmt::format("not an abort reply: status {}", status->code));
  }
}

std::expected<pr6xx::Status, ProtocolError> parse_last_error(std::string_view reply) {
  return pr6xx::parse_status(reply);
}

std::string format_poll_reply(const PollReply& reply, const pr6xx::ReplyStyle& style) {
  if (reply.state == PollReply::State::measuring) return pr6xx::format_setup_status(kMeasuring, style);
  const int code = reply.code.value_or(0);
  if (code < 0 && reply.tail.empty()) return pr6xx::format_error(code, style);
  const std::string status = pr6xx::format_setup_status(0, style);
  const std::string tail = reply.tail.empty() ? fmt::format("{}", code) : reply.tail;
  return fmt::format("{},{}\r\n", status.substr(0, status.size() - 2), tail);
}

std::string format_abort_reply(const AbortReply& reply, const pr6xx::ReplyStyle& style) {
  switch (reply.result) {
    case AbortReply::Result::aborted:
      return pr6xx::format_setup_status(0, style);
    case AbortReply::Result::nothing_running:
      return pr6xx::format_setup_status(kMeasuring, style);
    case AbortReply::Result::refused:
      return pr6xx::format_error(reply.code, style);
  }
  return pr6xx::format_setup_status(0, style);
}

}  // namespace skinspec::drivers::pr7xx
