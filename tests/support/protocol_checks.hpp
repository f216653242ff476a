#pragma once
// Helpers for the protocol suites: reply bytes shown readably, the error of a reply that must be
// refused, and the test data files of a meter family.

#include <gtest/gtest.h>

#include <expected>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>

#include "skinspec/drivers/protocol_error.hpp"

namespace skinspec::testing {

// CR, LF and other control bytes escaped, for failure messages.
inline std::string printable(std::string_view bytes) {
  std::string out;
  for (const char c : bytes) {
    if (c == '\r') {
      out += "\\r";
    } else if (c == '\n') {
      out += "\\n";
    } else if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) {
      out += "\\x" + std::to_string(static_cast<unsigned char>(c));
    } else {
      out += c;
    }
  }
  return out;
}

// Editing replies by line: replace, remove or repeat a line, or replace text everywhere.
inline std::string replace_all(std::string text, std::string_view from, std::string_view to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

// The byte offset where 1-based reply line `line` starts (bare CRs count as line ends).
inline std::size_t line_start(std::string_view reply, std::size_t line) {
  std::size_t at = 0;
  for (std::size_t n = 1; n < line; ++n) {
    at = reply.find_first_of("\r\n", at);
    at += (reply.substr(at, 2) == "\r\n") ? 2 : 1;
  }
  return at;
}

// Reply line `line` (1-based) without its line end.
inline std::string line_text(std::string_view reply, std::size_t line) {
  const std::size_t start = line_start(reply, line);
  return std::string(reply.substr(start, reply.find_first_of("\r\n", start) - start));
}

inline std::string replace_line(std::string reply, std::size_t line, std::string_view text) {
  const std::size_t start = line_start(reply, line);
  reply.replace(start, reply.find_first_of("\r\n", start) - start, text);
  return reply;
}

inline std::string remove_line(std::string reply, std::size_t line) {
  const std::size_t start = line_start(reply, line);
  reply.erase(start, line_start(reply, line + 1) - start);
  return reply;
}

inline std::string duplicate_line(std::string reply, std::size_t line) {
  const std::size_t start = line_start(reply, line);
  const std::size_t end = line_start(reply, line + 1);
  reply.insert(end, reply.substr(start, end - start));
  return reply;
}

// The error of a reply that must be refused; fails the test when it is accepted.
template <typename T>
drivers::ProtocolError error_of(const std::expected<T, drivers::ProtocolError>& result, std::string_view reply) {
  if (result) {
    ADD_FAILURE() << "accepted: " << printable(reply.substr(0, 200));
    return {drivers::ProtocolError::Kind::garbled, "", 0};
  }
  return result.error();
}

// The bytes of `directory`/`name`, exactly (fails the test when the file is missing).
inline std::string file_bytes(const std::string& directory, const std::string& name) {
  std::ifstream in(directory + "/" + name, std::ios::binary);
  if (!in) {
    ADD_FAILURE() << "missing test data file " << name;
    return {};
  }
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace skinspec::testing

// The reply is refused with an error of that kind.
#define EXPECT_KIND(result, reply, expected_kind)                                              \
  EXPECT_EQ(::skinspec::drivers::to_string(::skinspec::testing::error_of(result, reply).kind), \
            ::skinspec::drivers::to_string(expected_kind))                                     \
      << ::skinspec::testing::printable(std::string_view(reply).substr(0, 200))
