#pragma once
// The setup of a newer meter (PR-655 and later) and what its S commands do to it (private to
// simulator/). Pure: the model's limits come from its MeterProfile, never from its name.

#include <cstddef>
#include <optional>
#include <string_view>

#include "skinspec/drivers/meter_profile.hpp"

namespace skinspec::simulator::detail {

// Status codes the newer meters answer setup commands with (docs/pr6xx-protocol.md).
inline constexpr int kIllegalCommand = -1000;
inline constexpr int kBadExposure = -1010;
inline constexpr int kBadSync = -1019;
inline constexpr int kNotThisModel = -1035;

struct RemoteSetup {
  int exposure_ms = 0;    // 0: adaptive
  bool extended = false;  // SH1: the longer exposure range
  int cycles = 1;         // SN: measurements averaged
  enum class Sync { none, automatic, user } sync = Sync::none;
  int sync_hz = 60;  // SK, for user sync
  int aperture = 0;  // SF, a D117 code
  bool si_units = false;
};

// The apertures D117 lists and SF accepts, on models that have them.
inline constexpr std::string_view kApertureNames[] = {"1 deg", "1/2 deg", "1/4 deg", "1/8 deg"};

// Applies a setup command ("SE00250", "SS1", "SK060", ...; upper case, without terminator) and
// returns its status: 0, or the code the meter refuses it with (the setup then unchanged).
// `firmware` decides which spelling of the sync command it knows.
int apply_remote_setup(std::string_view command, const drivers::MeterProfile& profile,
                       const drivers::Firmware& firmware, RemoteSetup& setup);

// A parameter of digits only ("0250"), at most `max_digits` of them.
std::optional<int> whole_number(std::string_view digits, std::size_t max_digits);

// The longest exposure of the sensitivity in use.
int max_exposure_ms(const RemoteSetup& setup, const drivers::MeterProfile& profile);

}  // namespace skinspec::simulator::detail
