#pragma once
// Driver settings for tests (the PR-650 and the newer meters): short timeouts, so that silence
// is noticed quickly, and no pacing; the logic is the same at full length.

#include <chrono>

#include "skinspec/drivers/pr650.hpp"
#include "skinspec/drivers/remote_options.hpp"

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

inline drivers::RemoteOptions fast_remote() {
  using namespace std::chrono_literals;
  drivers::RemoteOptions o;
  o.pacing = 0ms;
  o.modem_settle = 0ms;
  o.timing.banner = 200ms;
  o.timing.confirm = 200ms;
  o.timing.quit_pause = 5ms;
  o.timing.retry_pause = 5ms;
  o.timing.reply = 300ms;
  o.timing.flicker = 300ms;
  o.timing.measurement_overhead = 300ms;
  o.timing.idle = 50ms;
  o.timing.poll_interval = 5ms;
  o.timing.line_bytes_per_second = 1e6;
  return o;
}

}  // namespace skinspec::testing
