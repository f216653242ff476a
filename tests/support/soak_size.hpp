#pragma once
// Test helper: how long a soak runs. The suites run a size that fits the test presets' 60 s;
// scripts/soak runs the same suites far longer by naming a size in the environment.

#include <charconv>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

namespace skinspec::testing {

// The positive count in environment variable `variable`, or `in_ci` when it is unset. A value
// that is not a positive count is refused: a soak that silently ran its CI size would be
// recorded as the long one.
inline int soak_size(const char* variable, int in_ci) {
  const char* text = std::getenv(variable);
  if (text == nullptr) return in_ci;
  const std::string_view value(text);
  int n = 0;
  const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), n);
  if (error != std::errc{} || end != value.data() + value.size() || n <= 0)
    throw std::invalid_argument(std::string(variable) + "=" + std::string(value) + " is not a positive count");
  return n;
}

}  // namespace skinspec::testing
