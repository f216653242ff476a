#pragma once
// Small helpers shared by the supervisor's source files.

#include <chrono>
#include <string>

#include "skinspec/drivers/pr650.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::daemon {

inline store::Time to_store_time(std::chrono::system_clock::time_point t) {
  return std::chrono::floor<std::chrono::microseconds>(t);
}

inline std::string describe(const drivers::InstrumentError& e) {
  return std::string(drivers::to_string(e.kind)) + ": " + e.message;
}

}  // namespace skinspec::daemon
