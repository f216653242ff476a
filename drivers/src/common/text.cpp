#include "common/text.hpp"

#include <algorithm>
#include <cctype>

#include <charconv>
#include <cmath>
#include <system_error>
#include <utility>

#include <fmt/format.h>

namespace skinspec::drivers::detail {

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

bool equal_ignoring_case(char a, char b) {
  return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
}

// Whether `text` starts with `prefix`, ignoring case (a meter may echo in either case).
bool starts_with_ignoring_case(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() && std::equal(prefix.begin(), prefix.end(), text.begin(), equal_ignoring_case);
}

std::string_view drop_leading_prompts(std::string_view text) {
  while (!text.empty() && is_prompt_or_blank(text.front())) text.remove_prefix(1);
  return text;
}

std::string_view drop_trailing_prompts(std::string_view text) {
  while (!text.empty() && is_prompt_or_blank(text.back())) text.remove_suffix(1);
  return text;
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

bool all_digits(std::string_view text) {
  for (const char c : text) {
    if (!is_digit(c)) return false;
  }
  return true;
}

bool is_printable(std::string_view text) {
  for (const char c : text) {
    if (c < 0x20 || c > 0x7e) return false;
  }
  return true;
}

std::expected<Line, ProtocolError> first_line(std::string_view reply, LineSplitter& lines) {
  if (auto line = lines.next_content()) return *line;
  if (reply.find_first_of("\r\n") == std::string_view::npos) {
    return std::unexpected(make_error(ProtocolError::Kind::truncated, 0, "the reply is empty"));
  }
  return std::unexpected(make_error(ProtocolError::Kind::garbled, 0, "the reply holds only blank lines and prompts"));
}

std::optional<ProtocolError> check_tail(LineSplitter& lines) {
  while (auto line = lines.next()) {
    if (!is_prompt_or_blank(line->text)) {
      return make_error(ProtocolError::Kind::surplus, line->number,
                        "unexpected bytes after the reply: " + quoted(line->text));
    }
  }
  return std::nullopt;
}

std::optional<ProtocolError> check_end(const Line& line, LineSplitter& rest) {
  if (!line.terminated) return make_error(ProtocolError::Kind::truncated, line.number, "the reply has no line end");
  return check_tail(rest);
}

std::vector<std::string_view> split_fields(std::string_view text) {
  std::vector<std::string_view> fields;
  for (;;) {
    const auto comma = text.find(',');
    fields.push_back(text.substr(0, comma));
    if (comma == std::string_view::npos) return fields;
    text.remove_prefix(comma + 1);
  }
}

std::expected<std::vector<std::string_view>, ProtocolError> match_fields(const Line& line,
                                                                         std::span<const FieldSpec> specs) {
  using Kind = ProtocolError::Kind;
  auto fields = split_fields(line.text);
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (i >= fields.size()) {
      return std::unexpected(
          make_error(Kind::truncated, line.number,
                     fmt::format("{} of {} fields: {}", fields.size(), specs.size(), quoted(line.text))));
    }
    const Match match = specs[i].match(fields[i]);
    if (match == Match::prefix && i + 1 == fields.size()) {
      return std::unexpected(
          make_error(Kind::truncated, line.number,
                     fmt::format("field {} ({}) is cut short: {}", i + 1, specs[i].name, quoted(fields[i]))));
    }
    if (match != Match::full) {
      return std::unexpected(
          make_error(Kind::garbled, line.number,
                     fmt::format("field {} is not a {}: {}", i + 1, specs[i].name, quoted(fields[i]))));
    }
  }
  if (fields.size() > specs.size()) {
    return std::unexpected(make_error(Kind::surplus, line.number,
                                      fmt::format("more than {} fields: {}", specs.size(), quoted(line.text))));
  }
  return fields;
}

std::size_t end_of_content_lines(std::string_view received, int enough) {
  int ended = 0;
  bool has_content = false;
  for (std::size_t i = 0; i < received.size(); ++i) {
    const char c = received[i];
    if (is_line_end(c)) {
      if (has_content && ++ended >= enough)
        return i + (c == '\r' && i + 1 < received.size() && received[i + 1] == '\n' ? 2 : 1);
      has_content = false;
    } else if (!is_prompt_or_blank(c)) {
      has_content = true;
    }
  }
  return 0;
}

std::string_view strip_echo(std::string_view reply, std::string_view command) {
  while (!command.empty() && is_line_end(command.back())) command.remove_suffix(1);
  std::string_view rest = drop_leading_prompts(reply);
  if (!command.empty() && starts_with_ignoring_case(rest, command)) {
    rest.remove_prefix(command.size());
    // The echoed terminator: whatever was sent, or the CR LF the meter may turn it into.
    if (rest.starts_with("\r\n")) {
      rest.remove_prefix(2);
    } else if (!rest.empty() && is_line_end(rest.front())) {
      rest.remove_prefix(1);
    }
  } else if (!command.empty() && starts_with_ignoring_case(command, rest)) {
    // Only part of the echo has arrived so far: there is no reply yet. Replies that start
    // with a letter ("Backlight set to 3 %") differ from their command by the second byte,
    // so at most one byte waits for the next.
    return rest.substr(rest.size());
  }
  return drop_trailing_prompts(rest);
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

std::unexpected<ProtocolError> fail(ProtocolError::Kind kind, std::size_t line, std::string_view message) {
  return std::unexpected(make_error(kind, line, message));
}

}  // namespace skinspec::drivers::detail
