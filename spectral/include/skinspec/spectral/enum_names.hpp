#pragma once
// An enumeration's names as a table of (value, name) pairs, read both ways: for the options
// and parameters that name a choice (--scale, ?format=).

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>
#include <utility>

namespace skinspec {

template <typename Enum, std::size_t N>
using EnumNames = std::array<std::pair<Enum, std::string_view>, N>;

// The name of `value`; "?" for one the table leaves out.
template <typename Enum, std::size_t N>
constexpr std::string_view name_of(const EnumNames<Enum, N>& names, Enum value) {
  for (const auto& [v, name] : names)
    if (v == value) return name;
  return "?";
}

// The value named `name` exactly; nullopt for a name the table does not hold.
template <typename Enum, std::size_t N>
constexpr std::optional<Enum> value_named(const EnumNames<Enum, N>& names, std::string_view name) {
  for (const auto& [v, n] : names)
    if (n == name) return v;
  return std::nullopt;
}

}  // namespace skinspec
