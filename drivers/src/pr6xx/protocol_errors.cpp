// The error codes of the PR-655/670/680 and PR-7xx. Their manuals print the same table, so one
// table serves both families; the manual's meanings are kept where drivers in the field read a
// code differently (docs/pr6xx-protocol.md, "Error codes").

#include <fmt/format.h>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx {

namespace {

struct ErrorEntry {
  int code;
  ErrorClass error_class;
  std::string_view message;
};

constexpr ErrorEntry kErrors[] = {
    {0, ErrorClass::ok, "measurement OK"},
    {1, ErrorClass::busy, "busy measuring"},
    {-1, ErrorClass::source_not_constant, "light source not constant"},
    {-2, ErrorClass::overload, "light overload"},
    {-3, ErrorClass::sync, "cannot sync to the light source (below 20 Hz, above 400 Hz, or too weak)"},
    {-4, ErrorClass::adaptive, "adaptive-mode error"},
    {-8, ErrorClass::too_dark, "weak light"},
    {-9, ErrorClass::sync, "sync error"},
    {-10, ErrorClass::sync, "cannot auto-sync"},
    {-12, ErrorClass::unstable_source, "adaptive exposure timed out (light source unstable)"},
    {-1000, ErrorClass::command_rejected, "illegal command"},
    {-1010, ErrorClass::command_rejected, "bad exposure time"},
    {-1019, ErrorClass::command_rejected, "bad sync mode"},
    {-1035, ErrorClass::command_rejected, "not applicable to this model"},
    {-2000, ErrorClass::no_data, "no such report, or no measurement yet"},
};

// The manuals list -1000 to -1035 as parse errors, most without a message of their own.
constexpr int kFirstParseError = -1035, kLastParseError = -1000;

const ErrorEntry* find(int code) {
  for (const auto& entry : kErrors) {
    if (entry.code == code) return &entry;
  }
  return nullptr;
}

}  // namespace

ErrorClass classify(int code) {
  if (const auto* entry = find(code)) return entry->error_class;
  if (code >= kFirstParseError && code <= kLastParseError) return ErrorClass::command_rejected;
  return ErrorClass::unknown;
}

std::string_view to_string(ErrorClass error_class) {
  switch (error_class) {
    case ErrorClass::ok:
      return "ok";
    case ErrorClass::too_dark:
      return "too_dark";
    case ErrorClass::overload:
      return "overload";
    case ErrorClass::sync:
      return "sync";
    case ErrorClass::source_not_constant:
      return "source_not_constant";
    case ErrorClass::adaptive:
      return "adaptive";
    case ErrorClass::unstable_source:
      return "unstable_source";
    case ErrorClass::command_rejected:
      return "command_rejected";
    case ErrorClass::no_data:
      return "no_data";
    case ErrorClass::busy:
      return "busy";
    case ErrorClass::unknown:
      return "unknown";
  }
  return "unknown";
}

std::string error_message(int code) {
  if (const auto* entry = find(code)) return fmt::format("{} ({})", entry->message, code);
  if (classify(code) == ErrorClass::command_rejected) return fmt::format("parse error ({})", code);
  return fmt::format("unknown error code {}", code);
}

}  // namespace skinspec::drivers::pr6xx
