#pragma once
// Text helpers shared by the protocol sources of every meter family (private to drivers/):
// splitting replies into lines, matching fixed-width fields, the echo a meter may send back,
// and building ProtocolErrors.

#include <cstddef>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/protocol_error.hpp"

namespace skinspec::drivers::detail {

// One line of a reply without its line end. Numbers count every line end from the start of
// the reply, empty lines included, so that an error names the line a person would count.
struct Line {
  std::string_view text;
  std::size_t number = 0;
  bool terminated = false;  // false only for bytes after the last line end
};

// Splits bytes into lines on CR, LF or CR LF. A bare CR counts as a line end because the
// PR-650's spectral header H1 ends its first line with one, and some meters end every line
// with one; a CR at the very end of the bytes also counts, as nothing says an LF will follow.
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

// Blanks and the '>' prompt a meter prints in echo mode: tolerated around a reply.
inline bool is_prompt_or_blank(char c) { return c == ' ' || c == '>'; }
bool is_prompt_or_blank(std::string_view text);
inline bool is_line_end(char c) { return c == '\r' || c == '\n'; }

// How far a text matches a field layout: completely, as a proper prefix (so that more bytes
// could complete it), or not at all.
enum class Match { full, prefix, mismatch };

// Matches `text` against a fixed-width template in which 'd' is a digit, 'x' an exponent
// letter (E or e) and 's' a sign; every other template character stands for itself.
Match match_template(std::string_view text, std::string_view pattern);

// The fixed layout of a value with a two-digit exponent, as every meter prints it.
inline constexpr std::string_view kValueTemplate = "d.dddxsdd";  // 5.882E-05

// A chromaticity: ".3355" (the PR-650) or "0.4035" (the newer meters).
Match match_chromaticity(std::string_view text);
// A decimal number of unknown width: digits with an optional point and exponent, and a sign
// when `allow_sign`. Used where the layout is not known (CCT, deviation, frequency, D120).
Match match_decimal(std::string_view text, bool allow_sign);

// The value of text that one of the matchers above accepted in full; nothing if it does not
// fit in a finite double.
std::optional<double> to_double(std::string_view text);
// The value of a run of decimal digits (at most 9, so it fits an int).
int digits_value(std::string_view digits);

bool all_digits(std::string_view text);
// Only bytes 0x20-0x7e.
bool is_printable(std::string_view text);

// ---- Replies made of lines and comma-separated fields --------------------------------------

// The first line of a reply that holds more than blanks and prompts.
std::expected<Line, ProtocolError> first_line(std::string_view reply, LineSplitter& lines);
// After a reply's last line only blank lines and '>' prompts may follow.
std::optional<ProtocolError> check_tail(LineSplitter& lines);
// A one-line reply must end with its line end and have nothing but noise after it.
std::optional<ProtocolError> check_end(const Line& line, LineSplitter& rest);

// One field of a comma-separated line: how its text must look, and what to call it.
struct FieldSpec {
  Match (*match)(std::string_view text);
  const char* name;
};
std::vector<std::string_view> split_fields(std::string_view text);
// The texts of a line made of exactly the fields in `specs`. A field that could still be
// completed is cut short when the line ends with it; in the middle of a line it is wrong.
std::expected<std::vector<std::string_view>, ProtocolError> match_fields(const Line& line,
                                                                         std::span<const FieldSpec> specs);

// Where the `enough`th line that holds something other than blanks and prompts ends (past a
// CR LF pair), or 0 before then. Every CR and every LF ends a line (a CR LF pair ends one);
// empty lines do not count.
std::size_t end_of_content_lines(std::string_view received, int enough);

// The reply with a leading echo of `command` (in either case, with the terminator the meter
// may turn into CR LF) and any '>' prompts and blanks around it removed. While only part of
// the echo has arrived, the result is empty: there is no reply yet.
std::string_view strip_echo(std::string_view reply, std::string_view command);

// A short, printable rendering of reply bytes for error messages.
std::string quoted(std::string_view bytes);

ProtocolError make_error(ProtocolError::Kind kind, std::size_t line, std::string_view message);
// make_error, as a parser's failed result.
std::unexpected<ProtocolError> fail(ProtocolError::Kind kind, std::size_t line, std::string_view message);

}  // namespace skinspec::drivers::detail
