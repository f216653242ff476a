#include "meter_settings.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

namespace skinspec::daemon {

using nlohmann::json;

namespace {

drivers::MeasureOptions::Sync sync_mode(api::SyncRequest::Mode mode) {
  switch (mode) {
    case api::SyncRequest::Mode::off:
      return drivers::MeasureOptions::Sync::off;
    case api::SyncRequest::Mode::automatic:
      return drivers::MeasureOptions::Sync::automatic;
    case api::SyncRequest::Mode::frequency:
      return drivers::MeasureOptions::Sync::frequency;
  }
  return drivers::MeasureOptions::Sync::off;
}

std::string name_of(const drivers::SettingLimits& limits) {
  return limits.model ? std::string(drivers::profile(*limits.model).name) : std::string("any model");
}

// "the PR-670's range", or before a model is known "what any model takes".
std::string whose_range(const drivers::SettingLimits& limits) {
  return limits.model ? fmt::format("the {}'s range", name_of(limits)) : std::string("what any model takes");
}

api::ApiError unprocessable(std::string code, std::string message) {
  return api::ApiError{api::ErrorKind::unprocessable, std::move(code), std::move(message)};
}

api::ApiError refusal(const drivers::SettingLimits& limits, const drivers::MeasureOptions& options,
                      drivers::Setting setting) {
  switch (setting) {
    case drivers::Setting::integration_ms:
      return unprocessable(
          "out_of_range",
          fmt::format("'integration_ms' must be 0 (adaptive) or {} to {} ms ({}{})", limits.exposure.min_ms,
                      drivers::longest_exposure_ms(limits, options.extended_sensitivity), whose_range(limits),
                      options.extended_sensitivity ? " with extended sensitivity" : ""));
    case drivers::Setting::averages:
      return unprocessable("out_of_range",
                           fmt::format("'averages' must be 1 to {} ({})", limits.max_averages, whose_range(limits)));
    case drivers::Setting::sync:
      return unprocessable(
          "out_of_range",
          fmt::format("'sync' must be \"off\", \"auto\" or a frequency of {} to {} Hz{} ({})", limits.sync_min_hz,
                      limits.sync_max_hz, limits.sync_whole_hz ? " in whole hertz" : "", whose_range(limits)));
    case drivers::Setting::extended_sensitivity:
      return unprocessable(
          "unsupported_setting",
          fmt::format("'extended_sensitivity' must be false: the {} has no extended sensitivity", name_of(limits)));
    case drivers::Setting::aperture:
      return unprocessable(
          "unsupported_setting",
          fmt::format("'aperture' must be left out: the {} has no apertures to choose", name_of(limits)));
  }
  return unprocessable("invalid_value", "a setting the meter does not take");
}

std::optional<api::ApiError> unlisted_aperture(const drivers::SettingLimits& limits,
                                               const std::vector<std::string>& listed, const std::string& asked) {
  if (std::ranges::any_of(listed, [&](const std::string& name) { return drivers::same_aperture(name, asked); }))
    return std::nullopt;
  if (listed.empty())
    return unprocessable("unknown_aperture", fmt::format("'aperture': the {} lists no apertures", name_of(limits)));
  std::vector<std::string> quoted;
  for (const auto& name : listed) quoted.push_back(fmt::format("'{}'", name));
  return unprocessable("unknown_aperture",
                       fmt::format("'aperture' must be one of {} (the apertures the {} lists), not '{}'",
                                   fmt::join(quoted, ", "), name_of(limits), asked));
}

}  // namespace

drivers::MeasureOptions measure_options(const api::MeasureRequest& request) {
  drivers::MeasureOptions options;
  options.integration_ms = request.integration_ms;
  options.averages = request.averages;
  options.sync = sync_mode(request.sync.mode);
  options.sync_hz = request.sync.hz;
  options.extended_sensitivity = request.extended_sensitivity;
  options.aperture = request.aperture;
  return options;
}

std::optional<api::ApiError> check_settings(const MeterSettings& meter, const api::MeasureRequest& request) {
  const drivers::MeasureOptions options = measure_options(request);
  if (const auto setting = drivers::refused_setting(meter.limits, options))
    return refusal(meter.limits, options, *setting);
  // The names are the meter's own: until it was reached the driver checks them when it measures.
  if (!options.aperture.empty() && meter.apertures)
    return unlisted_aperture(meter.limits, *meter.apertures, options.aperture);
  return std::nullopt;
}

json capabilities_json(const MeterSettings& meter) {
  const drivers::SettingLimits& limits = meter.limits;
  if (!limits.model) return nullptr;
  const json sync_modes = {api::sync_json({api::SyncRequest::Mode::off, 0}),
                           api::sync_json({api::SyncRequest::Mode::automatic, 0}), "frequency"};
  return {{"model", std::string(drivers::profile(*limits.model).id)},
          {"integration_ms",
           {{"min", limits.exposure.min_ms},
            {"max", limits.exposure.max_ms},
            {"max_extended", limits.extended_sensitivity ? json(limits.exposure.max_extended_ms) : json(nullptr)}}},
          {"averages", {{"min", 1}, {"max", limits.max_averages}}},
          {"sync",
           {{"modes", sync_modes},
            {"min_hz", limits.sync_min_hz},
            {"max_hz", limits.sync_max_hz},
            {"whole_hz", limits.sync_whole_hz}}},
          {"extended_sensitivity", limits.extended_sensitivity},
          {"apertures", meter.apertures ? json(*meter.apertures) : json(nullptr)}};
}

}  // namespace skinspec::daemon
