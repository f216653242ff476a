#pragma once
// What a meter takes for each setting of a measurement (MeasureOptions), as data, and the one
// check of the options against it: a driver refuses what its model does not take before a byte
// is sent, and skinspecd refuses a job that asks for it and shows the connected meter's settings
// from the same data. Apertures are the meter's own (D117), so only the meter can name them.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/meter_profile.hpp"

namespace skinspec::drivers {

inline constexpr int kMaxAverages = 99;  // SN01-SN99; the PR-650's setup field has two digits too

// The settings one model takes, or with no model those any model takes (for a meter not yet
// identified).
struct SettingLimits {
  std::optional<Model> model;  // nullopt: any model
  ExposureRange exposure;      // max_extended_ms 0: no extended sensitivity
  int max_averages = kMaxAverages;
  int sync_min_hz = 0, sync_max_hz = 0;
  bool sync_whole_hz = false;  // SKfff takes whole hertz; the PR-650's setup takes fractions
  bool extended_sensitivity = false;
  bool aperture = false;
};

SettingLimits setting_limits(std::optional<Model> model);

enum class Setting : std::uint8_t { integration_ms, averages, sync, extended_sensitivity, aperture };

// The longest exposure the limits take, with or without extended sensitivity.
int longest_exposure_ms(const SettingLimits& limits, bool extended);

// The first setting of `options` the limits do not take; nullopt when they take every one. An
// aperture is refused only by a model without apertures to choose: whether the meter lists the
// name is for whoever holds its list (same_aperture).
std::optional<Setting> refused_setting(const SettingLimits& limits, const MeasureOptions& options);

// Why `setting` of `options` is refused, naming what the limits take: "100 averages: the PR-670
// takes 1-99".
std::string refusal_message(const SettingLimits& limits, const MeasureOptions& options, Setting setting);

// Whether `asked` names the aperture the meter lists as `listed` ("1/2 deg"): case and blanks do
// not matter, as people type them.
bool same_aperture(std::string_view listed, std::string_view asked);

}  // namespace skinspec::drivers
