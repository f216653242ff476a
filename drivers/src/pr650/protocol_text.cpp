#include "pr650/protocol_text.hpp"

#include <charconv>
#include <cmath>
#include <system_error>
#include <utility>

#include <fmt/format.h>

namespace skinspec::drivers::pr650::detail {

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

bool fits_template_char(char c, char pattern) {
  switch (pattern) {
    case 'd':
      return is_digit(c);
    case 'x':
      return c == 'E' || c == 'e';
    case 's':
      return c == '+' || c == '-';
    default:
      return c == pattern;
  }
}

}  // namespace

std::optional<Line> LineSplitter::next() {
  if (rest_.empty()) return std::nullopt;
  const auto end = rest_.find_first_of("\r\n");
  ++lines_read_;
  if (end == std::string_view::npos) {
    const Line line{rest_, lines_read_, false};
    rest_ = {};
    return line;
  }
  const Line line{rest_.substr(0, end), lines_read_, true};
  const bool crlf = rest_[end] == '\r' && end + 1 < rest_.size() && rest_[end + 1] == '\n';
  rest_.remove_prefix(end + (crlf ? 2 : 1));
  return line;
}

std::optional<Line> LineSplitter::next_non_empty() {
  auto line = next();
  while (line && line->text.empty()) line = next();
  return line;
}

std::optional<Line> LineSplitter::next_content() {
  auto line = next();
  while (line && is_prompt_or_blank(line->text)) line = next();
  return line;
}

bool is_prompt_or_blank(std::string_view text) {
  for (const char c : text) {
    if (!is_prompt_or_blank(c)) return false;
  }
  return true;
}

Match match_template(std::string_view text, std::string_view pattern) {
  if (text.size() > pattern.size()) {
    // Longer than the layout: a mismatch, whatever the first bytes look like.
    return Match::mismatch;
  }
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (!fits_template_char(text[i], pattern[i])) return Match::mismatch;
  }
  return text.size() == pattern.size() ? Match::full : Match::prefix;
}

Match match_chromaticity(std::string_view text) {
  const Match bare = match_template(text, ".dddd");
  const Match padded = match_template(text, "0.dddd");
  if (bare == Match::full || padded == Match::full) return Match::full;
  if (bare == Match::prefix || padded == Match::prefix) return Match::prefix;
  return Match::mismatch;
}

Match match_decimal(std::string_view text, bool allow_sign) {
  std::size_t i = 0;
  const auto digits_from = [&](std::size_t from) {
    std::size_t j = from;
    while (j < text.size() && is_digit(text[j])) ++j;
    return j;
  };
  if (allow_sign && i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  const std::size_t integer_end = digits_from(i);
  std::size_t mantissa_digits = integer_end - i;
  i = integer_end;
  if (i < text.size() && text[i] == '.') {
    const std::size_t fraction_end = digits_from(i + 1);
    mantissa_digits += fraction_end - (i + 1);
    i = fraction_end;
  }
  if (i == text.size()) return mantissa_digits > 0 ? Match::full : Match::prefix;
  if (mantissa_digits == 0 || (text[i] != 'E' && text[i] != 'e')) return Match::mismatch;
  ++i;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  const std::size_t exponent_end = digits_from(i);
  if (exponent_end != text.size()) return Match::mismatch;
  return exponent_end > i ? Match::full : Match::prefix;
}

std::optional<double> to_double(std::string_view text) {
  // std::from_chars takes no leading '+'; the matchers have already checked the rest.
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{} || end != text.data() + text.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

int digits_value(std::string_view digits) {
  int value = 0;
  for (const char c : digits) value = value * 10 + (c - '0');
  return value;
}

std::string quoted(std::string_view bytes) {
  constexpr std::size_t kShown = 32;
  std::string out = "\"";
  for (const char c : bytes.substr(0, kShown)) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '\r') {
      out += "\\r";
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (byte < 0x20 || byte > 0x7e) {
      out += fmt::format("\\x{:02x}", byte);
    } else {
      out += c;
    }
  }
  out += bytes.size() > kShown ? "\"..." : "\"";
  return out;
}

ProtocolError make_error(ProtocolError::Kind kind, std::size_t line, std::string_view message) {
  std::string text = line > 0 ? fmt::format("line {}: {}", line, message) : std::string(message);
  return ProtocolError{kind, std::move(text), line};
}

}  // namespace skinspec::drivers::pr650::detail
