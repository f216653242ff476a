#include "text.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>

#include "skinspec/spectral/utf8.hpp"

namespace skinspec::text {

std::string_view trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

namespace {

// Line ends as the spectral formats count them: LF, CRLF, or CR alone.
std::size_t line_ends(std::string_view text) {
  std::size_t ends = 0;
  for (std::size_t i = 0; i < text.size(); ++i)
    ends += text[i] == '\n' || (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n'));
  return ends;
}

}  // namespace

std::optional<InputError> utf8_error(std::string_view text, std::size_t first_line, std::string_view source) {
  constexpr std::size_t kContext = 24;  // bytes of the text before the defect, to find it by
  const auto defect = utf8::first_defect(text);
  if (!defect) return std::nullopt;
  const auto last_end = text.substr(0, defect->offset).find_last_of("\r\n");
  const std::size_t line_start = last_end == std::string_view::npos ? 0 : last_end + 1;
  const auto line = text.substr(line_start, text.find_first_of("\r\n", defect->offset) - line_start);
  const std::size_t offset = defect->offset - line_start;
  std::size_t from = offset > kContext ? offset - kContext : 0;
  while (from < offset && (static_cast<unsigned char>(line[from]) & 0xC0) == 0x80) ++from;
  const auto before = line.substr(from, offset - from);
  const auto bad = line.substr(offset, defect->length);
  std::string message = fmt::format("{} is not UTF-8 text", printable(bad));
  if (!before.empty()) message += fmt::format(" (after {}{})", from > 0 ? "..." : "", quote(before));
  return InputError{std::string(source), first_line + line_ends(text.substr(0, line_start)), offset + 1,
                    message + "; the file must be saved as UTF-8"};
}

std::expected<csv::Row, InputError> read_utf8_row(csv::Reader& reader, std::string_view source) {
  auto row = reader.read_row();
  if (!row)
    return std::unexpected(InputError{std::string(source), row.error().line, 0, std::move(row.error().message)});
  if (auto defect = utf8_error(row->bytes, row->line, source)) return std::unexpected(std::move(*defect));
  return std::move(*row);
}

std::expected<double, std::string> parse_number(std::string_view cell) {
  const auto text = trim(cell);
  if (text.empty()) return std::unexpected(std::string("empty cell where a number is expected"));
  double value = 0;
  const char* first = text.data();
  if (*first == '+') ++first;  // from_chars refuses a leading '+', spreadsheets write one
  const auto [end, ec] = std::from_chars(first, text.data() + text.size(), value);
  if (ec == std::errc::result_out_of_range) return std::unexpected(quote(text) + " is out of range");
  if (ec != std::errc() || end != text.data() + text.size()) return std::unexpected(quote(text) + " is not a number");
  if (!std::isfinite(value)) return std::unexpected(quote(text) + " is not a finite number");
  return value;
}

}  // namespace skinspec::text
