#pragma once
// Driver settings for tests: short timeouts, so that silence is noticed quickly; the logic is
// the same at full length.

#include <chrono>

#include "skinspec/drivers/pr650.hpp"

namespace skinspec::testing {

inline drivers::DriverOptions fast_driver() {
  using namespace std::chrono_literals;
  drivers::DriverOptions o;
  o.contact_attempts = 3;
  o.modem_settle = 0ms;
  o.timing.contact = 100ms;
  o.timing.reply = 300ms;
  o.timing.measurement_overhead = 300ms;
  o.timing.adaptive_allowance = 300ms;
  o.timing.idle = 100ms;
  o.timing.line_bytes_per_second = 1e6;
  return o;
}

}  // namespace skinspec::testing
