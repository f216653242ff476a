#pragma once
// Text helpers shared by the PR-650 protocol sources (private to drivers/): splitting replies
// into lines, matching the meter's fixed-width fields, and building ProtocolErrors.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650::detail {

// One line of a reply without its line end. Numbers count every line end from the start of
// the reply, empty lines included, so that an error names the line a person would count.
struct Line {
  std::string_view text;
  std::size_t number = 0;
  bool terminated = false;  // false only for bytes after the last line end
};

// Splits bytes into lines on CR, LF or CR LF. A bare CR counts as a line end because the
// spectral header H1 ends its first line with one; a CR at the very end of the bytes also
// counts, as nothing says an LF will follow.
class LineSplitter {
 public:
  explicit LineSplitter(std::string_view bytes) : rest_(bytes) {}

  // The next line, or nothing once every byte has been read.
  std::optional<Line> next();
  // The next line that holds at least one byte (empty lines are harmless line-end noise).
  std::optional<Line> next_non_empty();
  // The next line that is not only blanks and '>' prompts.
  std::optional<Line> next_content();

  std::size_t lines_read() const { return lines_read_; }

 private:
  std::string_view rest_;
  std::size_t lines_read_ = 0;
};

// Blanks and the '>' prompt the meter prints in echo mode: tolerated around a reply.
inline bool is_prompt_or_blank(char c) { return c == ' ' || c == '>'; }
bool is_prompt_or_blank(std::string_view text);
inline bool is_line_end(char c) { return c == '\r' || c == '\n'; }

// How far a text matches a field layout: completely, as a proper prefix (so that more bytes
// could complete it), or not at all.
enum class Match { full, prefix, mismatch };

// Matches `text` against a fixed-width template in which 'd' is a digit, 'x' an exponent
// letter (E or e) and 's' a sign; every other template character stands for itself.
Match match_template(std::string_view text, std::string_view pattern);

// The fixed layouts of the meter's numbers.
inline constexpr std::string_view kValueTemplate = "d.dddxsdd";           // 5.882E-05
inline constexpr std::string_view kDataLineTemplate = "dddd.,d.dddxsdd";  // 0380.,5.882E-05

// A chromaticity: ".3355", also "0.3355" (harmless, and other firmware prints it).
Match match_chromaticity(std::string_view text);
// A decimal number of unknown width: digits with an optional point and exponent, and a sign
// when `allow_sign`. Used where the layout is not known (CCT, deviation, frequency, D120).
Match match_decimal(std::string_view text, bool allow_sign);

// The value of text that one of the matchers above accepted in full; nothing if it does not
// fit in a finite double.
std::optional<double> to_double(std::string_view text);
// The value of a run of decimal digits (at most 9, so it fits an int).
int digits_value(std::string_view digits);

// A short, printable rendering of reply bytes for error messages.
std::string quoted(std::string_view bytes);

ProtocolError make_error(ProtocolError::Kind kind, std::size_t line, std::string_view message);

}  // namespace skinspec::drivers::pr650::detail
