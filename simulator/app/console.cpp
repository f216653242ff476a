#include "console.hpp"

#include <fmt/format.h>

#include <cstdio>

namespace skinspec::sim_app {

void Console::announce(std::string_view line) {
  std::lock_guard lock(mutex_);
  fmt::print(stdout, "{}\n", line);
  std::fflush(stdout);
}

void Console::note(std::string_view line) {
  if (quiet_) return;
  std::lock_guard lock(mutex_);
  fmt::print(stderr, "skinspec-sim: {}\n", line);
}

void Console::error(std::string_view line) {
  std::lock_guard lock(mutex_);
  fmt::print(stderr, "skinspec-sim: {}\n", line);
}

}  // namespace skinspec::sim_app
