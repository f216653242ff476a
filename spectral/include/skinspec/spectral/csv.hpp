#pragma once
// The one CSV tokenizer of skinspec's readers (the spectra files, the data tables, the
// importer): RFC 4180 rows, with fields quoted or not, doubled quotes inside quotes, and commas
// and line ends kept inside quotes. Lines end in LF or CRLF; a lone CR ends a line too, or is
// refused, as the reader is told. Lines of spaces and tabs alone are passed over. Each row and
// each cell says on which line it starts, so that a reader's messages can name it. Bytes in,
// rows out: what the cells mean is the caller's.

#include <cstddef>
#include <deque>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::csv {

enum class LoneCr {
  refused,    // "a line ends in a carriage return alone"
  ends_line,  // as LF and CRLF do
};

struct Cell {
  std::string_view text;   // without its quotes, doubled quotes made single; blanks kept
  std::size_t line = 0;    // from 1, where the cell starts
  std::size_t column = 0;  // 1-based byte position of its first byte (a quote, if quoted) in that line
};

struct Row {
  std::size_t line = 0;    // from 1, where the row starts
  std::string_view bytes;  // as the input holds it, without its line end
  std::vector<Cell> cells;
};

struct Line {
  std::string_view text;   // without its line end
  std::size_t number = 0;  // from 1
};

struct Error {
  std::size_t line = 0;
  std::string message;
};

class Reader {
 public:
  explicit Reader(std::string_view bytes, LoneCr lone_cr = LoneCr::refused);
  // Cells view text the reader unescaped: they live as long as the reader.
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // The line the next row starts on, unread; nullopt at the end. A caller for whom some lines
  // are not CSV (comments, metadata) looks here first and skips them.
  std::optional<Line> peek() const;
  void skip_line();
  // The row at peek(): its cells, over as many lines as its quotes hold. Call only when peek()
  // has a line.
  std::expected<Row, Error> read_row();

 private:
  std::size_t text_end(std::size_t from) const;     // where the text of the line from `from` ends
  std::size_t line_end_size(std::size_t at) const;  // 1 or 2 when a line ends at `at`, else 0
  void pass_blank_lines();
  // Reads the cells from pos_ up to the row's end, where `i` is left.
  std::expected<void, Error> read_cells(Row& row, std::size_t& i);

  std::string_view bytes_;
  LoneCr lone_cr_;
  std::size_t pos_ = 0;                // where the next line starts
  std::size_t line_ = 1;               // its number
  std::size_t width_ = 0;              // the last row's cells, to reserve room for the next
  std::deque<std::string> unescaped_;  // the text of quoted cells (a deque: it never moves)
};

}  // namespace skinspec::csv
