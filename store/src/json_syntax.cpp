#include "json_syntax.hpp"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <vector>

namespace skinspec::store::detail {

namespace {

constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";

// A reader over the text that checks one token at a time; each check leaves the reader after
// its token and says whether the token was well formed.
class Reader {
 public:
  explicit Reader(std::string_view text)
      : at_(reinterpret_cast<const unsigned char*>(text.data())), end_(at_ + text.size()) {}

  // The next byte, or 0 at the end (never a byte a token may start or go on with there).
  unsigned char peek() const { return at_ == end_ ? 0 : *at_; }

  bool take(unsigned char c) {
    if (peek() != c) return false;
    ++at_;
    return true;
  }

  void skip_whitespace() {
    while (at_ != end_ && (*at_ == ' ' || *at_ == '\n' || *at_ == '\r' || *at_ == '\t')) ++at_;
  }

  bool literal(std::string_view word) {
    if (static_cast<std::size_t>(end_ - at_) < word.size()) return false;
    for (const char c : word)
      if (*at_++ != static_cast<unsigned char>(c)) return false;
    return true;
  }

  static constexpr long kExponentCap = 100'000'000'000'000'000L;

  // -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?, of a magnitude a double can hold: the JSON
  // reader refuses a number that overflows to infinity. Only a number whose decimal exponent
  // comes near the limit is converted to find out.
  bool number() {
    const unsigned char* const start = at_;
    take('-');
    long magnitude = 0;  // about the decimal exponent of the number's first digit that is not 0
    const unsigned char* const integer = at_;
    if (!take('0')) {
      if (!is_digit(peek())) return false;
      skip_digits();
      magnitude = at_ - integer - 1;
    }
    if (take('.')) {
      const unsigned char* const fraction = at_;
      if (!digits()) return false;
      if (magnitude == 0 && *integer == '0') {
        const unsigned char* first = fraction;
        while (first != at_ && *first == '0') ++first;
        magnitude = -(first - fraction + 1);
      }
    }
    if (take('e') || take('E')) {
      const bool negative = !take('+') && take('-');
      if (!is_digit(peek())) return false;
      // Held below 10^17: beyond the digits any text can have, and far from overflowing.
      long exponent = 0;
      for (; at_ != end_ && is_digit(*at_); ++at_) exponent = std::min(exponent * 10 + (*at_ - '0'), kExponentCap);
      magnitude += negative ? -exponent : exponent;
    }
    return magnitude < 300 || fits_a_double(start);
  }

  // After the opening quote, up to and past the closing one.
  bool string() {
    for (;;) {
      if (at_ == end_) return false;
      const unsigned char c = *at_;
      if (c == '"') {
        ++at_;
        return true;
      }
      if (c < 0x20) return false;
      if (c == '\\') {
        ++at_;
        if (!escape()) return false;
      } else if (c < 0x80) {
        ++at_;
      } else if (!utf8_sequence()) {
        return false;
      }
    }
  }

 private:
  static bool is_digit(unsigned char c) { return c >= '0' && c <= '9'; }

  // Whether the number from `start` to the reader is finite as a double (correctly rounded, as
  // the reader's strtod rounds it).
  bool fits_a_double(const unsigned char* start) const {
    double value = 0;
    const auto [end, error] =
        std::from_chars(reinterpret_cast<const char*>(start), reinterpret_cast<const char*>(at_), value);
    return error == std::errc{} && end == reinterpret_cast<const char*>(at_);
  }
  void skip_digits() {
    while (at_ != end_ && is_digit(*at_)) ++at_;
  }
  bool digits() {
    if (!is_digit(peek())) return false;
    skip_digits();
    return true;
  }

  // After the backslash. A \u escape of a high surrogate must be followed by one of a low
  // surrogate, and a low surrogate may not stand alone: JSON text is Unicode.
  bool escape() {
    if (at_ == end_) return false;
    const unsigned char c = *at_++;
    if (c != 'u') return std::string_view("\"\\/bfnrt").find(static_cast<char>(c)) != std::string_view::npos;
    std::uint32_t unit = 0;
    if (!hex4(unit)) return false;
    if (unit >= 0xDC00 && unit <= 0xDFFF) return false;
    if (unit < 0xD800 || unit > 0xDBFF) return true;
    std::uint32_t low = 0;
    return take('\\') && take('u') && hex4(low) && low >= 0xDC00 && low <= 0xDFFF;
  }

  bool hex4(std::uint32_t& unit) {
    if (end_ - at_ < 4) return false;
    for (int i = 0; i < 4; ++i) {
      const unsigned char c = *at_++;
      unit <<= 4;
      if (c >= '0' && c <= '9') unit |= c - '0';
      else if (c >= 'a' && c <= 'f') unit |= c - 'a' + 10u;
      else if (c >= 'A' && c <= 'F') unit |= c - 'A' + 10u;
      else return false;
    }
    return true;
  }

  // One character of two to four bytes, as RFC 3629's table allows: no overlong forms, no
  // surrogates, nothing past U+10FFFF.
  bool utf8_sequence() {
    const unsigned char lead = *at_++;
    int continuation = 0;
    unsigned char low = 0x80, high = 0xBF;  // the range of the first continuation byte
    if (lead >= 0xC2 && lead <= 0xDF) {
      continuation = 1;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      continuation = 2;
      if (lead == 0xE0) low = 0xA0;
      if (lead == 0xED) high = 0x9F;
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      continuation = 3;
      if (lead == 0xF0) low = 0x90;
      if (lead == 0xF4) high = 0x8F;
    } else {
      return false;
    }
    for (int i = 0; i < continuation; ++i, low = 0x80, high = 0xBF) {
      if (at_ == end_ || *at_ < low || *at_ > high) return false;
      ++at_;
    }
    return true;
  }

  const unsigned char* at_;
  const unsigned char* end_;
};

// The value at the reader, and every value nested in it, without recursion: `open` holds the
// objects and arrays entered and not yet closed, so any depth costs memory, not stack.
bool value(Reader& in) {
  std::vector<unsigned char> open;
  // After an object's '{' or ',': a member's name and colon, before its value.
  const auto member_name = [&] {
    in.skip_whitespace();
    if (!in.take('"') || !in.string()) return false;
    in.skip_whitespace();
    return in.take(':');
  };
  for (;;) {
    // One value begins here.
    in.skip_whitespace();
    bool complete = true;
    switch (in.peek()) {
      case '{':
        in.take('{');
        in.skip_whitespace();
        if (in.take('}')) break;
        if (!member_name()) return false;
        open.push_back('{');
        complete = false;
        break;
      case '[':
        in.take('[');
        in.skip_whitespace();
        if (in.take(']')) break;
        open.push_back('[');
        complete = false;
        break;
      case '"':
        in.take('"');
        if (!in.string()) return false;
        break;
      case 't':
        if (!in.literal("true")) return false;
        break;
      case 'f':
        if (!in.literal("false")) return false;
        break;
      case 'n':
        if (!in.literal("null")) return false;
        break;
      default:  // a number, or nothing JSON knows
        if (!in.number()) return false;
    }
    if (!complete) continue;
    // A value is complete: close what it completes, until the next value is due.
    for (;;) {
      if (open.empty()) return true;
      in.skip_whitespace();
      const unsigned char container = open.back();
      if (in.take(container == '{' ? '}' : ']')) {
        open.pop_back();
        continue;
      }
      if (!in.take(',')) return false;
      if (container == '{' && !member_name()) return false;
      break;
    }
  }
}

// As the JSON reader does, a NUL byte after the value ends the text: what follows is not read.
bool whole_value(std::string_view text, bool object_only) {
  if (text.starts_with(kByteOrderMark)) text.remove_prefix(kByteOrderMark.size());
  Reader in(text);
  in.skip_whitespace();
  if (object_only && in.peek() != '{') return false;
  if (!value(in)) return false;
  in.skip_whitespace();
  return in.peek() == 0;
}

}  // namespace

bool is_json_object(std::string_view text) { return whole_value(text, true); }

bool is_json(std::string_view text) { return whole_value(text, false); }

}  // namespace skinspec::store::detail
