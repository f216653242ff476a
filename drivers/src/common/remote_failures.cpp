#include "common/remote_failures.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::remote {

namespace p6 = pr6xx;

namespace {

InstrumentError bad_reading(int code, std::string_view cause, const std::string& raw) {
  return {InstrumentError::Kind::bad_reading, fmt::format("{} ({})", cause, code), code, raw};
}

}  // namespace

std::variant<MeasureAgain, InstrumentError> after_failure(int code, AttemptState& state, const MeterProfile& profile,
                                                          const std::string& raw) {
  const bool fixed = state.exposure_ms > 0;
  auto sync_off = [&]() -> std::variant<MeasureAgain, InstrumentError> {
    state.sync_on = false;
    state.sync_retried = true;
    return MeasureAgain{fmt::format("sync-off: the meter could not sync ({}); measured again without sync", code)};
  };
  auto unstable = [&](std::string_view cause) -> std::variant<MeasureAgain, InstrumentError> {
    if (state.unstable_retried) return bad_reading(code, cause, raw);
    state.unstable_retried = true;
    return MeasureAgain{fmt::format("unstable: {} ({}); measured again", cause, code)};
  };
  switch (p6::classify(code)) {
    case p6::ErrorClass::too_dark:
      // Never a spectrum of zeros, as some drivers in the field return for weak light.
      if (fixed && state.adjust_exposure && state.exposure_ms < state.max_exposure_ms) {
        const int before = state.exposure_ms;
        state.exposure_ms = std::min(2 * before, state.max_exposure_ms);
        return MeasureAgain{
            fmt::format("exposure: too dark at {} ms; measured again at {} ms", before, state.exposure_ms)};
      }
      return bad_reading(code, "too dark: weak light signal", raw);
    case p6::ErrorClass::overload:
      if (fixed && state.adjust_exposure && state.exposure_ms > profile.exposure.min_ms) {
        const int before = state.exposure_ms;
        state.exposure_ms = std::max(before / 2, profile.exposure.min_ms);
        return MeasureAgain{
            fmt::format("exposure: overload at {} ms; measured again at {} ms", before, state.exposure_ms)};
      }
      return bad_reading(code, "overload: the light saturates the detector", raw);
    case p6::ErrorClass::sync:
      if (state.sync_on && !state.sync_retried) return sync_off();
      return bad_reading(code, "cannot sync to the source", raw);
    case p6::ErrorClass::source_not_constant:
      // Under sync the meters report a failed sync this way too.
      if (state.sync_on && !state.sync_retried) return sync_off();
      return unstable("unstable source: light not constant");
    case p6::ErrorClass::adaptive:
    case p6::ErrorClass::unstable_source:
      return unstable("unstable source: adaptive exposure timed out");
    case p6::ErrorClass::command_rejected:
      return InstrumentError{InstrumentError::Kind::protocol,
                             fmt::format("the {} refused the measurement: {}", profile.name, p6::error_message(code)),
                             code, raw};
    case p6::ErrorClass::no_data:
      return InstrumentError{InstrumentError::Kind::protocol,
                             fmt::format("the {} has no measurement ({})", profile.name, code), code, raw};
    case p6::ErrorClass::ok:
    case p6::ErrorClass::busy:
    case p6::ErrorClass::unknown:
      break;
  }
  return InstrumentError{InstrumentError::Kind::bad_reading, p6::error_message(code), code, raw};
}

}  // namespace skinspec::drivers::remote
