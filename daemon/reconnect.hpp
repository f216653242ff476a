#pragma once
// When to try the instrument again after it was lost or could not be reached: exponential
// backoff, so that a meter that is off for the night costs a connection attempt every half
// minute and not a busy loop, while one that blinked is back within a second.

#include <chrono>

namespace skinspec::daemon {

struct BackoffPolicy {
  std::chrono::milliseconds initial{500};    // the wait after the first failed attempt
  std::chrono::milliseconds maximum{30000};  // the doubling stops here
};

// How long to wait before the next attempt after `failed_attempts` attempts in a row failed:
// none after a loss (0 failures: try again at once), then initial, 2 × initial, 4 × initial ...
// up to maximum.
std::chrono::milliseconds backoff_delay(const BackoffPolicy& policy, int failed_attempts);

}  // namespace skinspec::daemon
