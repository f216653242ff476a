#include <cctype>

#include "skinspec/drivers/identification.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::identification {

namespace {

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

bool starts_with_backlight(std::string_view text) {
  constexpr std::string_view kBacklight = "backlight";
  if (text.size() < kBacklight.size()) return false;
  for (std::size_t i = 0; i < kBacklight.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(text[i])) != kBacklight[i]) return false;
  return true;
}

// A reply only the newer meters print: a report led by a status, or a status wider than the
// PR-650's three digits, or negative.
bool newer_meter_reply(std::string_view reply) {
  if (starts_with_backlight(trim(reply))) return true;
  if (auto status = pr6xx::parse_status(reply)) return status->digits >= 4 || status->code < 0;
  if (auto report = pr6xx::parse_text_report(reply)) return report->status.digits >= 4;
  return false;
}

bool pr650_status(std::string_view reply) {
  auto status = pr650::parse_status(reply);
  return status && *status == 0;
}

}  // namespace

ContactAnswer classify_contact(std::string_view reply) {
  if (pr650_status(reply)) return ContactAnswer::pr650;
  if (newer_meter_reply(reply)) return ContactAnswer::newer_meter;
  return ContactAnswer::other;
}

PhotoAnswer classify_photo(std::string_view received) {
  if (trim(received).empty()) return PhotoAnswer::silence;
  if (pr6xx::split_banner(received).found == pr6xx::BannerSplit::Found::whole) return PhotoAnswer::banner;
  if (newer_meter_reply(received)) return PhotoAnswer::newer_meter;
  // The PR-650 frames on line ends: PHOTO sits in its line buffer, echoed in echo mode.
  if (received.find(pr6xx::kRemoteKeyword) != std::string_view::npos || received.find('>') != std::string_view::npos ||
      pr650_status(received))
    return PhotoAnswer::pr650;
  return PhotoAnswer::other;
}

}  // namespace skinspec::drivers::identification
