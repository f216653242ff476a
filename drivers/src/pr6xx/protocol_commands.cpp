// PR-6xx/7xx commands as bytes, and knowing where a reply starts (after the remote-mode banner
// and any echo) and where it ends.

#include <cctype>

#include <fmt/format.h>

#include "pr6xx/fields.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx {

namespace {

constexpr int kFiveDigitExposureLimit = 100000;

std::string_view skip_line_ends(std::string_view text) {
  while (!text.empty() && detail::is_line_end(text.front())) text.remove_prefix(1);
  return text;
}

// Whether the first line holding more than blanks and prompts carries a status other than 0:
// such a spectral reply is whole at that line.
bool leads_with_failure(std::string_view received) {
  detail::LineSplitter lines(received);
  const auto line = lines.next_content();
  if (!line || !line->terminated) return false;
  const auto leading = fields::leading_status(*line);
  return leading && leading->status.code != 0;
}

}  // namespace

std::string format_command(std::string_view body, const CommandStyle& style) {
  std::string out;
  out.reserve(body.size() + 1);
  for (const char c : body) out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  out += style.terminator;
  return out;
}

std::string format_report(int code, const CommandStyle& style) {
  return format_command(fmt::format("D{}", code), style);
}

std::string format_measure(int code, const CommandStyle& style) {
  return format_command(fmt::format("M{}", code), style);
}

std::string format_exposure(int ms, const CommandStyle& style) {
  // BL670 sends SE%05d, which the PR-670 is known to take; 7xx exposures need six digits.
  if (ms == 0) return format_command("SE0", style);
  if (ms < kFiveDigitExposureLimit) return format_command(fmt::format("SE{:05}", ms), style);
  return format_command(fmt::format("SE{}", ms), style);
}

std::string format_averages(int cycles, const CommandStyle& style) {
  return format_command(fmt::format("SN{:02}", cycles), style);
}

std::string format_sync_mode(SyncMode mode, const CommandStyle& style, SyncCommand spelling) {
  return format_command(fmt::format("{}{}", spelling == SyncCommand::sq ? "SQ" : "SS", static_cast<int>(mode)), style);
}

std::string format_sync_frequency(int hz, const CommandStyle& style) {
  return format_command(fmt::format("SK{:03}", hz), style);
}

std::string format_sensitivity(bool extended, const CommandStyle& style) {
  return format_command(extended ? "SH1" : "SH0", style);
}

std::string format_aperture(int code, const CommandStyle& style) {
  return format_command(fmt::format("SF{}", code), style);
}

std::string format_units(bool si, const CommandStyle& style) { return format_command(si ? "SU1" : "SU0", style); }

std::string format_flicker(const CommandStyle& style) { return format_command("F", style); }

bool command_complete(std::string_view pending) {
  if (pending == kRemoteKeyword || pending == kQuit) return true;
  return !pending.empty() && detail::is_line_end(pending.back());
}

BannerSplit split_banner(std::string_view received) {
  const std::string_view text = skip_line_ends(received);
  std::string_view banner = kBanner;
  // The banner's blank may have been lost, or eaten by a reader that trims.
  if (!text.empty() && text.front() != ' ') banner.remove_prefix(1);
  if (text.empty() || (text.size() < banner.size() && banner.starts_with(text))) {
    return {text.empty() ? BannerSplit::Found::none : BannerSplit::Found::partial, false, received};
  }
  if (!text.starts_with(banner)) return {BannerSplit::Found::none, false, received};
  std::string_view rest = text.substr(banner.size());
  bool line_end = false;
  if (rest.starts_with("\r\n")) {
    rest.remove_prefix(2);
    line_end = true;
  } else if (!rest.empty() && detail::is_line_end(rest.front())) {
    rest.remove_prefix(1);
    line_end = true;
  }
  return {BannerSplit::Found::whole, line_end, rest};
}

std::string_view strip_echo(std::string_view received, std::string_view command) {
  return detail::strip_echo(received, command);
}

std::size_t reply_size(ReplyShape shape, std::string_view received, int points) {
  switch (shape) {
    case ReplyShape::line:
      return detail::end_of_content_lines(received, 1);
    case ReplyShape::spectral:
      if (leads_with_failure(received)) return detail::end_of_content_lines(received, 1);
      return points > 0 ? detail::end_of_content_lines(received, 1 + points) : 0;
    case ReplyShape::listing: {
      const auto last_end = received.find_last_of("\r\n");
      return last_end == std::string_view::npos ? 0 : last_end + 1;
    }
  }
  return 0;
}

}  // namespace skinspec::drivers::pr6xx
