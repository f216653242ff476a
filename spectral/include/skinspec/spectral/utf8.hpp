#pragma once
// Text that came from outside (a file, a command line) checked for UTF-8 and made safe to quote
// in a message. Every message that quotes input goes through printable() or quote(), so that
// no byte of it can move a terminal's cursor, change its colours or break a JSON encoder.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace skinspec::utf8 {

// Where bytes stop being UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing past
// U+10FFFF): the offset of the first byte of the first ill-formed sequence and how many bytes
// are ill-formed from there on (at most 16), or nullopt when all of it is UTF-8.
struct Defect {
  std::size_t offset = 0;
  std::size_t length = 0;
};
std::optional<Defect> first_defect(std::string_view bytes);
bool is_valid(std::string_view bytes);

}  // namespace skinspec::utf8

namespace skinspec {

// `bytes` as they may be printed: UTF-8 text is kept, while control characters (C0, DEL, C1),
// the Unicode controls that reorder text (U+202A-202E, U+2066-2069) and every byte that is not
// UTF-8 are escaped: \t, \r, \n, \x1b, \xff, \u0085, \u202e. A backslash is kept as it is, so
// that printable(printable(x)) == printable(x) and a message can be made safe twice.
std::string printable(std::string_view bytes);
// printable(bytes) in single quotes: how a message quotes a value it was given. (Not named
// "quoted": std::quoted would win the overload for a std::string argument.)
std::string quote(std::string_view bytes);

}  // namespace skinspec
