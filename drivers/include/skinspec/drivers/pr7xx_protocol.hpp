#pragma once
// What the PR-7xx adds to the PR-6xx language (pr6xx_protocol.hpp): a measurement triggered
// with T, polled with P, aborted with A, and its outcome read with V, so that a long
// measurement can be followed and cancelled. Pure functions, like pr6xx_protocol.hpp.

#include <expected>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "skinspec/drivers/protocol_error.hpp"

namespace skinspec::drivers::pr7xx {

std::string format_trigger(const pr6xx::CommandStyle& style = {});     // "T\r"
std::string format_poll(const pr6xx::CommandStyle& style = {});        // "P\r"
std::string format_abort(const pr6xx::CommandStyle& style = {});       // "A\r"
std::string format_last_error(const pr6xx::CommandStyle& style = {});  // "V\r"

// T's immediate reply is undocumented: nothing at all (an empty or blank reply), or a status.
std::expected<std::optional<pr6xx::Status>, ProtocolError> parse_trigger(std::string_view reply);

// P: "0001" while measuring; "0000", "00000" or "0000,<anything>" when done; a negative status
// when the measurement failed.
struct PollReply {
  enum class State { measuring, done } state = State::done;
  std::optional<int> code;  // a negative status, or a whole number right after "0000,"
  std::string tail;         // whatever followed "0000,", kept for the log
};
std::expected<PollReply, ProtocolError> parse_poll(std::string_view reply);

// A: "0000" aborted, "0001" nothing was running; a negative status is the meter refusing.
struct AbortReply {
  enum class Result { aborted, nothing_running, refused } result = Result::aborted;
  int code = 0;
};
std::expected<AbortReply, ProtocolError> parse_abort(std::string_view reply);

// V: the last measurement's error code as a status ("00000", "-8", "-0008").
std::expected<pr6xx::Status, ProtocolError> parse_last_error(std::string_view reply);

// Replies as the meter prints them (for the simulator and tests).
std::string format_poll_reply(const PollReply& reply, const pr6xx::ReplyStyle& style);  // "0001\r\n", "0000,0\r\n"
std::string format_abort_reply(const AbortReply& reply, const pr6xx::ReplyStyle& style);

}  // namespace skinspec::drivers::pr7xx
