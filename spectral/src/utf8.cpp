#include "skinspec/spectral/utf8.hpp"

#include <fmt/format.h>

namespace skinspec::utf8 {

namespace {

constexpr std::size_t kMaxDefectLength = 16;

struct Decoded {
  std::size_t length = 0;  // 0: no well-formed sequence starts here
  char32_t code_point = 0;
};

bool continuation(unsigned char byte) { return (byte & 0xC0) == 0x80; }

// The well-formed sequence starting at bytes[at], by the table of Unicode 15, section 3.9
// (table 3-7): the lead byte fixes the length and the range allowed for the second byte.
Decoded decode(std::string_view bytes, std::size_t at) {
  const auto lead = static_cast<unsigned char>(bytes[at]);
  if (lead < 0x80) return {1, lead};
  std::size_t length = 0;
  unsigned char low = 0x80, high = 0xBF;
  char32_t value = 0;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2, value = lead & 0x1F;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3, value = lead & 0x0F;
    if (lead == 0xE0) low = 0xA0;   // overlong below U+0800
    if (lead == 0xED) high = 0x9F;  // surrogates U+D800-DFFF
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4, value = lead & 0x07;
    if (lead == 0xF0) low = 0x90;   // overlong below U+10000
    if (lead == 0xF4) high = 0x8F;  // past U+10FFFF
  } else {
    return {};  // a continuation byte, C0/C1 (overlong) or F5-FF
  }
  if (at + length > bytes.size()) return {};
  const auto second = static_cast<unsigned char>(bytes[at + 1]);
  if (second < low || second > high) return {};
  for (std::size_t k = 1; k < length; ++k) {
    const auto byte = static_cast<unsigned char>(bytes[at + k]);
    if (!continuation(byte)) return {};
    value = (value << 6) | (byte & 0x3F);
  }
  return {length, value};
}

}  // namespace

std::optional<Defect> first_defect(std::string_view bytes) {
  for (std::size_t at = 0; at < bytes.size();) {
    const auto here = decode(bytes, at);
    if (here.length > 0) {
      at += here.length;
      continue;
    }
    Defect defect{at, 1};
    while (defect.length < kMaxDefectLength && at + defect.length < bytes.size() &&
           decode(bytes, at + defect.length).length == 0)
      ++defect.length;
    return defect;
  }
  return std::nullopt;
}

bool is_valid(std::string_view bytes) { return !first_defect(bytes); }

}  // namespace skinspec::utf8

namespace skinspec {

namespace {

// Characters a terminal acts on rather than shows: C0 and C1 controls, DEL, and the bidirectional
// embeddings, overrides and isolates that make text read in an order other than its bytes'.
bool acts_on_terminal(char32_t c) {
  return c < 0x20 || (c >= 0x7F && c <= 0x9F) || (c >= 0x202A && c <= 0x202E) || (c >= 0x2066 && c <= 0x2069);
}

std::string escaped(char32_t c) {
  switch (c) {
    case U'\t':
      return "\\t";
    case U'\r':
      return "\\r";
    case U'\n':
      return "\\n";
    default:
      return c < 0x80 ? fmt::format("\\x{:02x}", static_cast<unsigned>(c))
                      : fmt::format("\\u{:04x}", static_cast<unsigned>(c));
  }
}

}  // namespace

std::string printable(std::string_view bytes) {
  std::string out;
  out.reserve(bytes.size());
  for (std::size_t at = 0; at < bytes.size();) {
    const auto here = utf8::decode(bytes, at);
    if (here.length == 0) {
      out += fmt::format("\\x{:02x}", static_cast<unsigned char>(bytes[at]));
      ++at;
      continue;
    }
    if (acts_on_terminal(here.code_point)) {
      out += escaped(here.code_point);
    } else {
      out.append(bytes.substr(at, here.length));
    }
    at += here.length;
  }
  return out;
}

std::string quote(std::string_view bytes) { return "'" + printable(bytes) + "'"; }

}  // namespace skinspec
