// The S commands of the newer meters, checked against the model's profile.

#include "remote_setup.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

namespace skinspec::simulator::detail {

namespace {

int set_exposure(std::optional<int> ms, const drivers::MeterProfile& profile, RemoteSetup& setup) {
  if (!ms) return kBadExposure;
  if (*ms != 0 && (*ms < profile.exposure.min_ms || *ms > max_exposure_ms(setup, profile))) return kBadExposure;
  setup.exposure_ms = *ms;
  return 0;
}

// SS, and SQ as the manuals' syntax line spells it; user sync is 3, or 2 in some texts.
int set_sync(std::optional<int> mode, RemoteSetup& setup) {
  if (!mode) return kBadSync;
  switch (*mode) {
    case 0:
      setup.sync = RemoteSetup::Sync::none;
      return 0;
    case 1:
      setup.sync = RemoteSetup::Sync::automatic;
      return 0;
    case 2:
    case 3:
      setup.sync = RemoteSetup::Sync::user;
      return 0;
    default:
      return kBadSync;
  }
}

int set_sync_frequency(std::optional<int> hz, const drivers::MeterProfile& profile, RemoteSetup& setup) {
  if (!hz || *hz < profile.sync_min_hz || *hz > profile.sync_max_hz) return kBadSync;
  setup.sync_hz = *hz;
  return 0;
}

int set_flag(std::optional<int> value, bool& flag) {
  if (!value || *value > 1) return kIllegalCommand;
  flag = *value == 1;
  return 0;
}

int set_aperture(std::optional<int> code, RemoteSetup& setup) {
  if (!code || *code >= static_cast<int>(std::size(kApertureNames))) return kIllegalCommand;
  setup.aperture = *code;
  return 0;
}

}  // namespace

std::optional<int> whole_number(std::string_view digits, std::size_t max_digits) {
  if (digits.empty() || digits.size() > max_digits ||
      !std::ranges::all_of(digits, [](unsigned char c) { return std::isdigit(c) != 0; }))
    return std::nullopt;
  int value = 0;
  std::from_chars(digits.data(), digits.data() + digits.size(), value);
  return value;
}

int max_exposure_ms(const RemoteSetup& setup, const drivers::MeterProfile& profile) {
  return setup.extended && profile.exposure.max_extended_ms > 0 ? profile.exposure.max_extended_ms
                                                                : profile.exposure.max_ms;
}

int apply_remote_setup(std::string_view command, const drivers::MeterProfile& profile,
                       const drivers::Firmware& firmware, RemoteSetup& setup) {
  if (command.size() < 2) return kIllegalCommand;
  const auto value = whole_number(command.substr(2), 7);
  const drivers::Capabilities& caps = profile.caps;
  switch (command[1]) {
    case 'E':
      return set_exposure(value, profile, setup);
    case 'N':
      if (!value || *value < 1 || *value > 99) return kIllegalCommand;
      setup.cycles = *value;
      return 0;
    // SS as the headings spell it, SQ as the syntax lines do: a firmware that follows its
    // syntax line strictly knows SQ only.
    case 'S':
      return firmware.sync == drivers::SyncCommand::sq ? kIllegalCommand : set_sync(value, setup);
    case 'Q':
      return set_sync(value, setup);
    case 'K':
      return set_sync_frequency(value, profile, setup);
    case 'H': {
      if (!caps.sensitivity || profile.exposure.max_extended_ms == 0) return kNotThisModel;
      const int status = set_flag(value, setup.extended);
      if (status == 0) setup.exposure_ms = std::min(setup.exposure_ms, max_exposure_ms(setup, profile));
      return status;
    }
    case 'F':
      return caps.aperture ? set_aperture(value, setup) : kNotThisModel;
    case 'D': {
      bool smart_dark = false;
      return caps.smart_dark ? set_flag(value, smart_dark) : kNotThisModel;
    }
    case 'U':
      return set_flag(value, setup.si_units);
    default:
      return kIllegalCommand;
  }
}

}  // namespace skinspec::simulator::detail
