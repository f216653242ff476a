#include "pr6xx/fields.hpp"

namespace skinspec::drivers::pr6xx::fields {

namespace {

constexpr std::size_t kStatusDigits = 5;
constexpr std::size_t kWholeDigits = 6;

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// A run of 1..max digits: prefix while empty.
Match match_digits(std::string_view text, std::size_t max) {
  if (text.empty()) return Match::prefix;
  return detail::all_digits(text) && text.size() <= max ? Match::full : Match::mismatch;
}

Match best_of(Match a, Match b) {
  if (a == Match::full || b == Match::full) return Match::full;
  if (a == Match::prefix || b == Match::prefix) return Match::prefix;
  return Match::mismatch;
}

std::string_view without_sign(std::string_view text) {
  if (!text.empty() && text.front() == '-') text.remove_prefix(1);
  return text;
}

}  // namespace

Match match_status(std::string_view text) { return match_digits(without_sign(text), kStatusDigits); }

Status status_value(std::string_view text) {
  const std::string_view digits = without_sign(text);
  const int magnitude = detail::digits_value(digits);
  return Status{digits.size() < text.size() ? -magnitude : magnitude, static_cast<int>(digits.size())};
}

Match match_units(std::string_view text) {
  const Match match = match_digits(text, 4);
  if (match != Match::full) return match;
  const int code = detail::digits_value(text);
  const bool known = code <= 3 || (code >= 11 && code <= 14) || (code >= 111 && code <= 114);
  return known ? Match::full : Match::mismatch;
}

Match match_value(std::string_view text) {
  const std::string_view unsigned_text = without_sign(text);
  return best_of(detail::match_template(unsigned_text, detail::kValueTemplate),
                 detail::match_template(unsigned_text, "d.dddxsddd"));
}

int exponent_digits(std::string_view value) {
  return static_cast<int>(without_sign(value).size() - std::string_view("d.dddxs").size());
}

Match match_whole(std::string_view text) { return match_digits(text, kWholeDigits); }

Match match_cct(std::string_view text) {
  const auto first_digit = text.find_first_not_of(' ');
  if (first_digit == std::string_view::npos) return Match::prefix;
  return match_digits(text.substr(first_digit), kWholeDigits);
}

Match match_number(std::string_view text) { return detail::match_decimal(text, false); }

Match match_signed_number(std::string_view text) { return detail::match_decimal(text, true); }

Match match_label(std::string_view text) {
  if (text.empty()) return Match::prefix;
  for (const char c : text) {
    if (c < 0x20 || c > 0x7e || c == ',') return Match::mismatch;
  }
  return Match::full;
}

std::expected<LeadingStatus, ProtocolError> leading_status(const detail::Line& line) {
  const auto comma = line.text.find(',');
  const std::string_view text = line.text.substr(0, comma);
  const Match match = match_status(text);
  if (match == Match::prefix && comma == std::string_view::npos && !line.terminated) {
    return detail::fail(ProtocolError::Kind::truncated, line.number,
                        "the status is cut short: " + detail::quoted(text));
  }
  if (match != Match::full) {
    return detail::fail(ProtocolError::Kind::garbled, line.number,
                        "expected a status such as 00000 or -8, got " + detail::quoted(line.text));
  }
  const Status status = status_value(text);
  // 0 is success, 1 busy, and errors are negative: another status is not a meter's.
  if (status.code > 1) {
    return detail::fail(ProtocolError::Kind::garbled, line.number,
                        "status " + detail::quoted(text) + " is neither 0, 1 nor an error code");
  }
  LeadingStatus result{status, std::nullopt};
  if (comma != std::string_view::npos) result.rest = line.text.substr(comma + 1);
  return result;
}

std::optional<double> number(std::string_view text) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);  // a CCT's alignment
  return detail::to_double(text);
}

int whole(std::string_view text) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  std::size_t digits = 0;
  while (digits < text.size() && is_digit(text[digits])) ++digits;
  return detail::digits_value(text.substr(0, digits));
}

}  // namespace skinspec::drivers::pr6xx::fields
