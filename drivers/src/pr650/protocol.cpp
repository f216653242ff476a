// PR-650 protocol: message tables, command formatting, and knowing when a reply is whole.
// Reply parsing lives in protocol_parse.cpp, reply formatting in protocol_format.cpp.

#include "skinspec/drivers/pr650_protocol.hpp"

#include <algorithm>
#include <cctype>
#include <utility>

#include <fmt/format.h>

#include "pr650/protocol_text.hpp"

namespace skinspec::drivers::pr650 {

namespace {

struct QualityEntry {
  int code;
  const char* message;
};

// Manual p. B-30, as quoted by BrainardLabToolbox and matched by the VB.NET driver.
constexpr QualityEntry kQualityTable[] = {
    {0, "Measurement OK"},
    {1, "No EOS (end-of-scan) signal at start of measurement"},
    {3, "No start signal"},
    {4, "No EOS signal to start integration time"},
    {5, "DMA failure"},
    {6, "No EOS after change to SYNC mode"},
    {7, "Cannot sync to light source"},
    {8, "Sync lost during measurement"},
    {10, "Weak light signal"},
    {12, "Unspecified hardware malfunction"},
    {13, "Software error"},
    {14, "No sample in L*u*v* or L*a*b* calculation"},
    {16,
     "Adaptive integration taking too long to find an integration time (light source "
     "probably unstable)"},
    {17, "Main battery low"},
    {18, "Low light level"},
    {19, "Light level too high (overload)"},
    {20, "No sync signal"},
    {21, "RAM error"},
    {29, "Corrupted data"},
    {30, "Noisy signal"},
};

// The command letter in the style's case, then its parameters and one terminator.
std::string make_command(char letter, std::string_view parameters, const CommandStyle& style) {
  const auto cased = style.upper_case ? std::toupper(static_cast<unsigned char>(letter))
                                      : std::tolower(static_cast<unsigned char>(letter));
  std::string out(1, static_cast<char>(cased));
  out += parameters;
  out += style.terminator;
  return out;
}

// A sync frequency as the meter reads it: "60", or "59.94" when it is not whole.
std::string format_frequency(double hz) {
  std::string text = fmt::format("{:.2f}", hz);
  while (text.back() == '0') text.pop_back();
  if (text.back() == '.') text.pop_back();
  return text;
}

std::string format_sync(const Setup& setup) {
  switch (setup.sync) {
    case Setup::Sync::none:
      return "";
    case Setup::Sync::last_measured:
      return "1";
    case Setup::Sync::frequency:
      return format_frequency(setup.sync_hz);
  }
  return "";
}

bool equal_ignoring_case(char a, char b) {
  return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
}

// Whether `text` starts with `prefix`, ignoring case (the meter may echo in either case).
bool starts_with_ignoring_case(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() && std::equal(prefix.begin(), prefix.end(), text.begin(), equal_ignoring_case);
}

std::string_view drop_leading_prompts(std::string_view text) {
  while (!text.empty() && detail::is_prompt_or_blank(text.front())) text.remove_prefix(1);
  return text;
}

std::string_view drop_trailing_prompts(std::string_view text) {
  while (!text.empty() && detail::is_prompt_or_blank(text.back())) text.remove_suffix(1);
  return text;
}

// Where the `enough`th line that holds something other than blanks and prompts ends (past a
// CR LF pair), or 0 before then. Every CR and every LF ends a line (a CR LF pair ends one);
// empty lines do not count.
std::size_t end_of_ended_lines(std::string_view received, int enough) {
  int ended = 0;
  bool has_content = false;
  for (std::size_t i = 0; i < received.size(); ++i) {
    const char c = received[i];
    if (detail::is_line_end(c)) {
      if (has_content && ++ended >= enough)
        return i + (c == '\r' && i + 1 < received.size() && received[i + 1] == '\n' ? 2 : 1);
      has_content = false;
    } else if (!detail::is_prompt_or_blank(c)) {
      has_content = true;
    }
  }
  return 0;
}

}  // namespace

std::string quality_message(int code) {
  for (const auto& entry : kQualityTable) {
    if (entry.code == code) return entry.message;
  }
  return fmt::format("unknown quality code {:02}", code);
}

const std::vector<int>& known_quality_codes() {
  static const std::vector<int> codes = [] {
    std::vector<int> all;
    for (const auto& entry : kQualityTable) all.push_back(entry.code);
    return all;
  }();
  return codes;
}

std::string format_backlight(int level, const CommandStyle& style) {
  return make_command('b', fmt::format("{}", level), style);
}

std::string format_setup(const Setup& setup, const CommandStyle& style) {
  const auto accessory = [](const std::optional<int>& code) {
    return code ? fmt::format("{:02}", *code) : std::string();
  };
  const std::string fields = fmt::format(
      "{:02},{},{},{},{},{},{:02},{}", setup.primary_accessory, accessory(setup.addons[0]), accessory(setup.addons[1]),
      accessory(setup.addons[2]), format_sync(setup), setup.integration_ms, setup.averages, setup.si_units ? 1 : 0);
  return make_command('s', fields, style);
}

std::string format_flicker(const CommandStyle& style) { return make_command('f', "", style); }

std::string format_measure(int report, const CommandStyle& style) {
  return make_command('m', fmt::format("{}", report), style);
}

std::string format_report(int report, const CommandStyle& style) {
  return make_command('d', fmt::format("{}", report), style);
}

std::string setup_reply_message(int code) {
  switch (code) {
    case 0:
      return "setup accepted";
    case 1:
      return "field 1 (primary accessory) is invalid";
    case 2:
      return "field 2 (add-on accessory 1) is invalid";
    case 3:
      return "field 3 (add-on accessory 2) is invalid";
    case 4:
      return "field 4 (add-on accessory 3) is invalid";
    case 5:
      return "field 5 (sync frequency) is invalid";
    case 6:
      return "field 6 (integration time) is invalid";
    case 7:
      return "field 7 (measurements to average) is invalid";
    case 8:
      return "field 8 (units) is invalid";
    case 50:
      return "no primary accessory given, more than one given, or field 1 is not a primary "
             "accessory";
    default:
      return fmt::format("unknown setup reply code {:02}", code);
  }
}

ReplyShape reply_shape_of_measure(int report) { return report == 5 ? ReplyShape::spectral : ReplyShape::line; }

ReplyShape reply_shape_of_report(int report) { return report == 5 ? ReplyShape::spectral : ReplyShape::line; }

std::size_t reply_size(ReplyShape shape, std::string_view received) {
  // A spectral report is its header (one line with a bare CR inside, or two lines: either
  // way two line ends) and 101 data lines. Anything else is one line.
  return end_of_ended_lines(received, shape == ReplyShape::spectral ? 2 + kSpectralPoints : 1);
}

bool reply_complete(ReplyShape shape, std::string_view received) { return reply_size(shape, received) > 0; }

std::string_view strip_echo(std::string_view reply, std::string_view command) {
  while (!command.empty() && detail::is_line_end(command.back())) command.remove_suffix(1);
  std::string_view rest = drop_leading_prompts(reply);
  if (!command.empty() && starts_with_ignoring_case(rest, command)) {
    rest.remove_prefix(command.size());
    // The echoed terminator: whatever was sent, or the CR LF the meter may turn it into.
    if (rest.starts_with("\r\n")) {
      rest.remove_prefix(2);
    } else if (!rest.empty() && detail::is_line_end(rest.front())) {
      rest.remove_prefix(1);
    }
  } else if (!command.empty() && starts_with_ignoring_case(command, rest)) {
    // Only part of the echo has arrived so far: there is no reply yet. Every known reply
    // starts with a digit while every command starts with a letter, so no reply is eaten.
    return rest.substr(rest.size());
  }
  return drop_trailing_prompts(rest);
}

}  // namespace skinspec::drivers::pr650
