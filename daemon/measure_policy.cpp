#include "measure_policy.hpp"

#include <cmath>

#include <fmt/format.h>

#include "skinspec/api/job_board.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

std::optional<std::string> check(const MeasurePolicy& policy) {
  if (policy.max_rejected_readings < 0 || policy.max_rejected_readings > 100)
    return fmt::format("max_rejected_readings {} is outside 0-100", policy.max_rejected_readings);
  if (!(policy.white_max_age_s > 0)) return fmt::format("white_max_age_s {} is not above 0", policy.white_max_age_s);
  if (!(policy.lamp_change_tolerance > 0) || !std::isfinite(policy.lamp_change_tolerance))
    return fmt::format("lamp_change_tolerance {} is not above 0", policy.lamp_change_tolerance);
  return std::nullopt;
}

double band_integrated(const store::SpectralSamples& radiance) {
  double sum = 0;
  const auto& wl = radiance.wavelength_nm;
  const auto& v = radiance.values;
  for (std::size_t i = 1; i < wl.size() && i < v.size(); ++i) sum += (wl[i] - wl[i - 1]) * (v[i] + v[i - 1]) / 2;
  return sum;
}

std::optional<std::string> white_age_warning(const store::Measurement& white, store::Time sample_started,
                                             const MeasurePolicy& policy) {
  const double age_s = std::chrono::duration<double>(sample_started - white.finished_at).count();
  if (age_s <= policy.white_max_age_s) return std::nullopt;
  return fmt::format(
      "white_stale: the white reference (measurement {}) was {:.1f} s old, more than white_max_age_s {:g}: "
      "measure the white standard again",
      white.id, age_s, policy.white_max_age_s);
}

std::optional<std::string> lamp_change_warning(const store::Measurement& white, const store::Measurement& previous,
                                               const MeasurePolicy& policy) {
  const double before = band_integrated(previous.radiance);
  const double now = band_integrated(white.radiance);
  if (!(before > 0)) return std::nullopt;  // a dark previous white tells nothing about the lamp
  const double change = (now - before) / before;
  if (std::abs(change) <= policy.lamp_change_tolerance) return std::nullopt;
  return fmt::format(
      "{} the band-integrated radiance of this white ({:.4g}) is {:+.1f} % from the previous white's "
      "(measurement {}, {:.4g}), beyond lamp_change_tolerance {:g} %",
      kLampChanged, now, 100 * change, previous.id, before, 100 * policy.lamp_change_tolerance);
}

std::optional<std::string> inherited_lamp_warning(const store::Measurement& white) {
  for (const auto& w : white.warnings)
    if (w.starts_with(kLampChanged))
      return fmt::format("{} measured against white {}, whose lamp level changed from the white before it",
                         kLampChanged, white.id);
  return std::nullopt;
}

std::string rejection_warning(int attempt, const drivers::InstrumentError& error, store::Id rejected_id) {
  return fmt::format("rejected_reading: reading attempt {} rejected ({}); its raw reply is rejected reading {}",
                     attempt, describe(error), rejected_id);
}

store::JobError job_error(const drivers::InstrumentError& error) {
  using Failure = drivers::InstrumentError::Kind;
  using Code = store::JobErrorCode;
  const auto code = [&] {
    switch (error.kind) {
      case Failure::no_contact:
        return Code::no_contact;
      case Failure::lost:
        return Code::lost;
      case Failure::protocol:
        return Code::protocol;
      case Failure::bad_reading:
        return Code::bad_reading;
      case Failure::rejected:
        return Code::rejected;
      case Failure::cancelled:
        return Code::cancelled;
      case Failure::transport:
        return Code::transport;
      case Failure::identification:
        return Code::identification;
    }
    return Code::internal;
  }();
  return {code, error.message};
}

store::JobError cancellation(store::JobErrorCode code) { return api::stop_error(code); }

store::JobState ended_state(const store::JobError& error) {
  const bool cancelled = error.code == store::JobErrorCode::cancelled || error.code == store::JobErrorCode::stopped;
  return cancelled ? store::JobState::cancelled : store::JobState::failed;
}

}  // namespace skinspec::daemon
