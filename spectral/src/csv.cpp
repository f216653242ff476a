#include "skinspec/spectral/csv.hpp"

#include <algorithm>
#include <utility>

namespace skinspec::csv {
namespace {

bool is_blank(std::string_view text) { return text.find_first_not_of(" \t") == std::string_view::npos; }

// One cell as it is read: a slice of the input while it has no quotes, an unescaped copy once
// it has one, so that most cells (numbers) cost no allocation.
class CellText {
 public:
  explicit CellText(std::string_view bytes) : bytes_(bytes) {}

  void begin(std::size_t at, std::size_t line, std::size_t column) {
    start_ = end_ = at, line_ = line, column_ = column, copied_ = false;
    copy_.clear();
  }
  // Bytes [from, to) of the input, taken as they are.
  void plain(std::size_t from, std::size_t to) {
    if (copied_) copy_.append(bytes_.substr(from, to - from));
    else end_ = to;
  }
  // Text that is not in the input as it stands (a doubled quote made single), or that follows
  // an opening quote.
  void unescaped(std::string_view text) {
    to_copy();
    copy_.append(text);
  }
  void opens_quote() { to_copy(); }
  // The cell, its copied text kept in `store` (begin() starts the next one afresh).
  Cell finish(std::deque<std::string>& store) {
    if (!copied_) return {bytes_.substr(start_, end_ - start_), line_, column_};
    return {store.emplace_back(std::move(copy_)), line_, column_};
  }

 private:
  void to_copy() {
    if (!copied_) copy_.assign(bytes_.substr(start_, end_ - start_)), copied_ = true;
  }

  std::string_view bytes_;
  std::size_t start_ = 0, end_ = 0, line_ = 0, column_ = 0;
  bool copied_ = false;
  std::string copy_;
};

}  // namespace

Reader::Reader(std::string_view bytes, LoneCr lone_cr) : bytes_(bytes), lone_cr_(lone_cr) { pass_blank_lines(); }

std::size_t Reader::text_end(std::size_t from) const {
  if (lone_cr_ == LoneCr::ends_line) return std::min(bytes_.find_first_of("\r\n", from), bytes_.size());
  const auto lf = bytes_.find('\n', from);
  if (lf == std::string_view::npos) return bytes_.size();
  return lf > from && bytes_[lf - 1] == '\r' ? lf - 1 : lf;
}

std::size_t Reader::line_end_size(std::size_t at) const {
  if (at >= bytes_.size()) return 0;
  if (bytes_[at] == '\n') return 1;
  if (bytes_[at] != '\r') return 0;
  if (at + 1 < bytes_.size() && bytes_[at + 1] == '\n') return 2;
  return lone_cr_ == LoneCr::ends_line ? 1 : 0;
}

void Reader::pass_blank_lines() {
  while (pos_ < bytes_.size()) {
    const auto end = text_end(pos_);
    if (!is_blank(bytes_.substr(pos_, end - pos_))) return;
    pos_ = end + line_end_size(end);
    ++line_;
  }
}

std::optional<Line> Reader::peek() const {
  if (pos_ >= bytes_.size()) return std::nullopt;
  return Line{bytes_.substr(pos_, text_end(pos_) - pos_), line_};
}

void Reader::skip_line() {
  const auto end = text_end(pos_);
  pos_ = end + line_end_size(end);
  ++line_;
  pass_blank_lines();
}

std::expected<Row, Error> Reader::read_row() {
  Row row{line_, {}, {}};
  // Rows are mostly as wide as the one before: room for that many cells at once, not grown a
  // cell at a time through the whole file.
  row.cells.reserve(width_);
  std::size_t i = pos_;
  if (auto read = read_cells(row, i); !read) return std::unexpected(std::move(read.error()));
  row.bytes = bytes_.substr(pos_, i - pos_);
  width_ = row.cells.size();
  const auto line_end = line_end_size(i);
  pos_ = i + line_end;
  if (line_end > 0) ++line_;
  pass_blank_lines();
  return row;
}

std::expected<void, Error> Reader::read_cells(Row& row, std::size_t& i) {
  std::size_t line_start = pos_;  // of the line `i` is on, for the cells' columns
  CellText cell(bytes_);
  cell.begin(i, line_, 1);
  bool quoted = false;
  while (i < bytes_.size()) {
    const char c = bytes_[i];
    if (quoted) {
      if (c == '"' && i + 1 < bytes_.size() && bytes_[i + 1] == '"') {
        cell.unescaped("\""), i += 2;
      } else if (c == '"') {
        quoted = false, ++i;
      } else if (const auto line_end = line_end_size(i); line_end > 0) {
        cell.unescaped(bytes_.substr(i, line_end)), i += line_end;
        ++line_, line_start = i;
      } else {
        // Up to the next quote or line end at once.
        const auto end = std::min(bytes_.find_first_of("\"\r\n", i + 1), bytes_.size());
        cell.unescaped(bytes_.substr(i, end - i)), i = end;
      }
    } else if (c == '"') {
      quoted = true, ++i;
      cell.opens_quote();
    } else if (c == ',') {
      row.cells.push_back(cell.finish(unescaped_)), ++i;
      cell.begin(i, line_, i - line_start + 1);
    } else if (c == '\n' || c == '\r') {
      if (line_end_size(i) > 0) break;
      return std::unexpected(
          Error{line_, "a line ends in a carriage return alone: save the file with LF or CRLF line ends"});
    } else {
      const auto end = std::min(bytes_.find_first_of(",\"\r\n", i + 1), bytes_.size());
      cell.plain(i, end), i = end;
    }
  }
  if (quoted) return std::unexpected(Error{row.line, "a quoted field is not closed"});
  row.cells.push_back(cell.finish(unescaped_));
  return {};
}

}  // namespace skinspec::csv
