#pragma once
// A whole field as a finite number ("+" allowed in front), as the file formats of records/ read
// them; nullopt for anything else.

#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>

namespace skinspec::records::detail {

inline std::optional<double> finite_number(std::string_view text) {
  double value = 0;
  const auto* first = text.data() + (text.starts_with('+') ? 1 : 0);
  const auto [end, error] = std::from_chars(first, text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace skinspec::records::detail
