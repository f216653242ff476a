// The settings each model takes, read from the model table (meter_profile.cpp), and the check
// every driver and skinspecd make against them.

#include "skinspec/drivers/measure_settings.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace skinspec::drivers {

namespace {

SettingLimits limits_of(const MeterProfile& row) {
  return {.model = row.model,
          .exposure = row.exposure,
          .sync_min_hz = row.sync_min_hz,
          .sync_max_hz = row.sync_max_hz,
          .sync_whole_hz = row.sync == SyncStyle::ss_sk,
          .extended_sensitivity = row.caps.sensitivity && row.exposure.max_extended_ms > 0,
          .aperture = row.caps.aperture};
}

// Before a meter is identified a job may ask for anything some model takes; the driver holds
// the identified model to its own limits.
SettingLimits any_model() {
  SettingLimits any;
  any.exposure = {std::numeric_limits<int>::max(), 0, 0};
  any.sync_min_hz = std::numeric_limits<int>::max();
  for (const MeterProfile& row : all_profiles()) {
    const SettingLimits one = limits_of(row);
    any.exposure.min_ms = std::min(any.exposure.min_ms, one.exposure.min_ms);
    any.exposure.max_ms = std::max(any.exposure.max_ms, one.exposure.max_ms);
    any.exposure.max_extended_ms = std::max(any.exposure.max_extended_ms, one.exposure.max_extended_ms);
    any.sync_min_hz = std::min(any.sync_min_hz, one.sync_min_hz);
    any.sync_max_hz = std::max(any.sync_max_hz, one.sync_max_hz);
    any.extended_sensitivity = any.extended_sensitivity || one.extended_sensitivity;
    any.aperture = any.aperture || one.aperture;
  }
  return any;
}

std::string who(const SettingLimits& limits) {
  return limits.model ? fmt::format("the {}", profile(*limits.model).name) : std::string("any model");
}

bool sync_takes(const SettingLimits& limits, double hz) {
  return hz >= limits.sync_min_hz && hz <= limits.sync_max_hz && (!limits.sync_whole_hz || hz == std::floor(hz));
}

std::string aperture_key(std::string_view name) {
  std::string key;
  for (const char c : name)
    if (c != ' ') key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return key;
}

}  // namespace

SettingLimits setting_limits(std::optional<Model> model) { return model ? limits_of(profile(*model)) : any_model(); }

int longest_exposure_ms(const SettingLimits& limits, bool extended) {
  return extended && limits.exposure.max_extended_ms > 0 ? limits.exposure.max_extended_ms : limits.exposure.max_ms;
}

std::optional<Setting> refused_setting(const SettingLimits& limits, const MeasureOptions& options) {
  if (options.extended_sensitivity && !limits.extended_sensitivity) return Setting::extended_sensitivity;
  if (!options.aperture.empty() && !limits.aperture) return Setting::aperture;
  const int ms = options.integration_ms;
  if (ms != 0 && (ms < limits.exposure.min_ms || ms > longest_exposure_ms(limits, options.extended_sensitivity)))
    return Setting::integration_ms;
  if (options.averages < 1 || options.averages > limits.max_averages) return Setting::averages;
  if (options.sync == MeasureOptions::Sync::frequency && !sync_takes(limits, options.sync_hz)) return Setting::sync;
  return std::nullopt;
}

std::string refusal_message(const SettingLimits& limits, const MeasureOptions& options, Setting setting) {
  switch (setting) {
    case Setting::extended_sensitivity:
      return fmt::format("{} has no extended sensitivity", who(limits));
    case Setting::aperture:
      return fmt::format("{} has no apertures to choose ('{}')", who(limits), options.aperture);
    case Setting::integration_ms:
      return fmt::format("exposure {} ms: {} takes {}-{} ms{}, or 0 for adaptive", options.integration_ms, who(limits),
                         limits.exposure.min_ms, longest_exposure_ms(limits, options.extended_sensitivity),
                         options.extended_sensitivity ? " with extended sensitivity" : "");
    case Setting::averages:
      return fmt::format("{} averages: {} takes 1-{}", options.averages, who(limits), limits.max_averages);
    case Setting::sync:
      return fmt::format("sync frequency {:g} Hz: {} syncs to {}", options.sync_hz, who(limits),
                         limits.sync_whole_hz
                             ? fmt::format("whole hertz from {} to {} Hz", limits.sync_min_hz, limits.sync_max_hz)
                             : fmt::format("{}-{} Hz", limits.sync_min_hz, limits.sync_max_hz));
  }
  return "unknown setting";
}

bool same_aperture(std::string_view listed, std::string_view asked) {
  return aperture_key(listed) == aperture_key(asked);
}

}  // namespace skinspec::drivers
