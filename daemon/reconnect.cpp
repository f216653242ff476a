#include "reconnect.hpp"

#include <algorithm>

namespace skinspec::daemon {

std::chrono::milliseconds backoff_delay(const BackoffPolicy& policy, int failed_attempts) {
  if (failed_attempts <= 0) return std::chrono::milliseconds{0};
  const auto ceiling = std::max(policy.maximum, policy.initial);
  auto delay = policy.initial;
  // Doubling stops at the ceiling, so no count of failures can overflow.
  for (int i = 1; i < failed_attempts && delay < ceiling; ++i) delay *= 2;
  return std::min(delay, ceiling);
}

}  // namespace skinspec::daemon
