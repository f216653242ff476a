#pragma once
// Small text helpers shared by the table and spectra parsers (private to spectral/).

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::text {

std::string_view trim(std::string_view s);

// Splits bytes into lines on LF, CRLF or CR, counting lines from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view bytes) : rest_(bytes) {}
  bool next(std::string_view& line, std::size_t& line_no);

 private:
  std::string_view rest_;
  std::size_t line_no_ = 0;
};

struct Cell {
  std::string_view text;
  std::size_t column;  // 1-based character position of the cell in its line
};

// Splits one line on commas. Quoting is not part of the format.
std::vector<Cell> split_csv(std::string_view line);

// Where a line stops being UTF-8: its 1-based column and a message quoting the bytes (escaped)
// and the text before them; nullopt when the whole line is UTF-8.
struct Utf8Defect {
  std::size_t column;
  std::string message;
};
std::optional<Utf8Defect> utf8_defect(std::string_view line);

// A finite decimal number (leading/trailing blanks allowed), or a message saying why not.
std::expected<double, std::string> parse_number(std::string_view cell);

}  // namespace skinspec::text
