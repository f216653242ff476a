#pragma once
// Text helpers of the router: UTF-8 validation, percent-decoding, query strings, timestamps.

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

// Percent-decodes `text`; nullopt on a malformed escape. '+' is a space only when `plus_space`.
std::optional<std::string> percent_decode(std::string_view text, bool plus_space);
// "a=1&b=2" → {a: 1, b: 2}; nullopt on a malformed escape, invalid UTF-8 or a repeated name.
std::optional<std::map<std::string, std::string>> parse_query(std::string_view query);
// RFC 3339 in UTC, "2026-01-02T03:04:05Z" or with up to six fraction digits.
std::optional<store::Time> parse_time(std::string_view text);
// As every record shows its times (records::json_time).
std::string format_time(store::Time time);

// `text` without the spaces and tabs around it (HTTP's optional whitespace, RFC 9110 5.6.3).
std::string_view trimmed(std::string_view text);

}  // namespace skinspec::api::detail
