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

bool LineReader::next(std::string_view& line, std::size_t& line_no) {
  if (rest_.empty()) return false;
  const auto end = rest_.find_first_of("\r\n");
  line = rest_.substr(0, end);
  if (end == std::string_view::npos) {
    rest_ = {};
  } else {
    const bool crlf = rest_[end] == '\r' && end + 1 < rest_.size() && rest_[end + 1] == '\n';
    rest_.remove_prefix(end + (crlf ? 2 : 1));
  }
  line_no = ++line_no_;
  return true;
}

std::vector<Cell> split_csv(std::string_view line) {
  std::vector<Cell> cells;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    cells.push_back({line.substr(start, comma - start), start + 1});
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

std::optional<Utf8Defect> utf8_defect(std::string_view line) {
  constexpr std::size_t kContext = 24;  // bytes of the text before the defect, to find it by
  const auto defect = utf8::first_defect(line);
  if (!defect) return std::nullopt;
  std::size_t from = defect->offset > kContext ? defect->offset - kContext : 0;
  while (from < defect->offset && (static_cast<unsigned char>(line[from]) & 0xC0) == 0x80) ++from;
  const auto before = line.substr(from, defect->offset - from);
  const auto bad = line.substr(defect->offset, defect->length);
  std::string message = fmt::format("{} is not UTF-8 text", printable(bad));
  if (!before.empty()) message += fmt::format(" (after {}{})", from > 0 ? "..." : "", quote(before));
  return Utf8Defect{defect->offset + 1, message + "; the file must be saved as UTF-8"};
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
