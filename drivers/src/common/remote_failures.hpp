#pragma once
// What a driver of the newer meters does when a measurement ends with one of the meter's error
// codes (docs/pr6xx-protocol.md, "Error policy"): measure again with a longer or shorter
// exposure, without sync, or as it was, each at most as often as the policy allows; or give up
// with the error that names the cause. Pure: the driver carries the state between attempts.

#include <string>
#include <variant>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/meter_profile.hpp"

namespace skinspec::drivers::remote {

struct AttemptState {
  int exposure_ms = 0;  // 0: adaptive
  bool sync_on = false;
  bool adjust_exposure = false;
  int max_exposure_ms = 0;        // the longest exposure of the sensitivity in use
  bool sync_retried = false;      // a sync failure is measured again once, without sync
  bool unstable_retried = false;  // an unstable source is measured again once
};

struct MeasureAgain {
  std::string warning;  // for the reading: "sync-off: ...", "exposure: ...", "unstable: ..."
};

// The next step after `code` (not 0); `state` is updated for the next attempt.
std::variant<MeasureAgain, InstrumentError> after_failure(int code, AttemptState& state, const MeterProfile& profile,
                                                          const std::string& raw);

}  // namespace skinspec::drivers::remote
