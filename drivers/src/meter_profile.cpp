// The model table. Sources per value are in docs/pr6xx-protocol.md ("Models"); values no source
// gives (the PR-680's grid and ranges, most simulator serials) are marked "derived" there.

#include "skinspec/drivers/meter_profile.hpp"

#include <algorithm>
#include <cctype>

namespace skinspec::drivers {

namespace {

using namespace std::chrono_literals;

constexpr Grid kGrid4nm{380, 780, 4, 101};
constexpr Grid kGrid2nm{380, 780, 2, 201};
constexpr Grid kGrid1nm{380, 780, 1, 401};
constexpr Grid kGridTo1080{380, 1080, 2, 351};
constexpr Grid kGridTo1100{380, 1100, 2, 361};

constexpr Capabilities kPr650Caps{};
constexpr Capabilities kPr655Caps{.remote_keyword = true};
constexpr Capabilities kPr670Caps{.remote_keyword = true, .sensitivity = true, .aperture = true, .smart_dark = true};
constexpr Capabilities kPr7xxCaps{
    .remote_keyword = true, .sensitivity = true, .aperture = true, .smart_dark = true, .trigger_poll_abort = true};

constexpr WireStyle kPr650Wire{.data_status_digits = 2, .setup_status_digits = 2, .exponent_letter = 'E'};
constexpr WireStyle kShortErrors{};
constexpr WireStyle kPr655Wire{.data_exponent_digits = 3};
constexpr WireStyle kPaddedErrors{.padded_errors = true};

// What each manual generation documents (docs/pr6xx-protocol.md, "Firmware generations"). The
// PR-730/735 manual of 2009 lists neither T, P, A nor V, and its syntax line spells sync SQ; the
// simulator takes it at its word, so that the driver's fallbacks are tried.
constexpr std::array<Firmware, 1> kPr655Firmware{{{"m655", false, SyncCommand::ss}}};
constexpr std::array<Firmware, 1> kPr680Firmware{{{"m680", false, SyncCommand::ss}}};
constexpr std::array<Firmware, 2> kPr730Firmware{{{"m7xx", true, SyncCommand::ss}, {"m730", false, SyncCommand::sq}}};
constexpr std::array<Firmware, 2> kPr740Firmware{{{"m7xx", true, SyncCommand::ss}, {"m740", true, SyncCommand::ss}}};
constexpr std::array<Firmware, 1> kPr788Firmware{{{"m7xx", true, SyncCommand::ss}}};

constexpr ExposureRange kPr670Exposure{6, 6000, 30000};
constexpr ExposureRange kPr7xxExposure{12, 120000, 300000};

// clang-format off
constexpr std::array<MeterProfile, 9> kProfiles{{
    {Model::pr650, Family::pr650, "pr650", "PR-650", "", kGrid4nm, {}, kGrid4nm, {10, 6000, 0},
     SyncStyle::setup_field, 40, 250, kPr650Caps, kPr650Wire, ErrorTable::pr650_quality, 0ms, "60912345", {}},
    {Model::pr655, Family::pr6xx, "pr655", "PR-655", "PR-655", kGrid4nm, {}, kGrid4nm, {3, 6000, 0},
     SyncStyle::ss_sk, 20, 400, kPr655Caps, kPr655Wire, ErrorTable::pr6xx, 50ms, "65500001", kPr655Firmware},
    {Model::pr670, Family::pr6xx, "pr670", "PR-670", "PR-670", kGrid2nm, {}, kGrid2nm, kPr670Exposure,
     SyncStyle::ss_sk, 20, 400, kPr670Caps, kShortErrors, ErrorTable::pr6xx, 50ms, "67065106", kPr655Firmware},
    // Nothing documents the PR-680's grid or ranges: the simulator gives it the PR-670's.
    {Model::pr680, Family::pr6xx, "pr680", "PR-680", "PR-680", std::nullopt, {}, kGrid2nm, kPr670Exposure,
     SyncStyle::ss_sk, 20, 400, kPr670Caps, kShortErrors, ErrorTable::pr6xx, 50ms, "68000001", kPr680Firmware},
    // The PR-730/735 and PR-740 manuals' D120 example shows the PR-670's 2 nm grid.
    {Model::pr730, Family::pr7xx, "pr730", "PR-730", "PR-730/735", kGrid1nm, {kGrid2nm}, kGrid1nm, kPr7xxExposure,
     SyncStyle::ss_sk, 20, 400, kPr7xxCaps, kShortErrors, ErrorTable::pr6xx, 50ms, "73000001", kPr730Firmware},
    // One manual ends the PR-735's range at 1100 nm, a later one at 1080 nm.
    {Model::pr735, Family::pr7xx, "pr735", "PR-735", "PR-730/735", kGridTo1080, {kGridTo1100}, kGridTo1080,
     kPr7xxExposure, SyncStyle::ss_sk, 20, 400, kPr7xxCaps, kShortErrors, ErrorTable::pr6xx, 50ms, "73500001", kPr730Firmware},
    {Model::pr740, Family::pr7xx, "pr740", "PR-740", "PR-740", kGrid1nm, {kGrid2nm}, kGrid1nm, kPr7xxExposure,
     SyncStyle::ss_sk, 20, 400, kPr7xxCaps, kPaddedErrors, ErrorTable::pr6xx, 50ms, "74000001", kPr740Firmware},
    {Model::pr745, Family::pr7xx, "pr745", "PR-745", "PR-745", kGridTo1080, {}, kGridTo1080, kPr7xxExposure,
     SyncStyle::ss_sk, 20, 400, kPr7xxCaps, kPaddedErrors, ErrorTable::pr6xx, 50ms, "74500001", kPr740Firmware},
    {Model::pr788, Family::pr7xx, "pr788", "PR-788", "PR-788", kGrid1nm, {}, kGrid1nm, kPr7xxExposure,
     SyncStyle::ss_sk, 20, 400, kPr7xxCaps, kPaddedErrors, ErrorTable::pr6xx, 50ms, "78800001", kPr788Firmware},
}};
// clang-format on

constexpr bool grid_ok(const std::optional<Grid>& grid) { return !grid || grid->consistent(); }

constexpr bool table_is_sound() {
  for (std::size_t i = 0; i < kProfiles.size(); ++i) {
    const MeterProfile& row = kProfiles[i];
    if (static_cast<std::size_t>(row.model) != i) return false;
    if (!grid_ok(row.grid) || !grid_ok(row.grid_variants[0]) || !grid_ok(row.grid_variants[1])) return false;
    if (!row.simulator_grid || !row.simulator_grid->consistent()) return false;
    if (row.grid && row.grid != row.simulator_grid) return false;
    const ExposureRange& e = row.exposure;
    if (e.min_ms <= 0 || e.max_ms <= e.min_ms || (e.max_extended_ms != 0 && e.max_extended_ms <= e.max_ms)) {
      return false;
    }
    if (row.caps.remote_keyword != (row.family != Family::pr650)) return false;
    if (row.caps.trigger_poll_abort != (row.family == Family::pr7xx)) return false;
    if (row.firmware.empty() != (row.family == Family::pr650)) return false;
    // The newest generation has every capability the row claims.
    if (!row.firmware.empty() && row.firmware.front().trigger_poll_abort != row.caps.trigger_poll_abort) return false;
  }
  return true;
}
static_assert(table_is_sound(), "every row in enum order, with consistent grids and ranges");

std::string upper_case(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// The model number of a profile: "670" for "pr670".
std::string_view model_number(const MeterProfile& row) { return row.id.substr(2); }

// "680L" -> "680": the digits of one '/'-separated part, letters after them being a variant.
// Empty when the part is not digits followed by letters.
std::string_view part_number(std::string_view part) {
  if (part.starts_with("PR")) part.remove_prefix(2);
  const auto digits = std::min(part.size(), part.find_first_not_of("0123456789"));
  if (digits == 0) return {};
  for (const char c : part.substr(digits)) {
    if (c < 'A' || c > 'Z') return {};
  }
  return part.substr(0, digits);
}

std::string_view trim_blanks(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

bool fits_grid(const MeterProfile& row, const Grid& grid) {
  return row.grid == grid || row.grid_variants[0] == grid || row.grid_variants[1] == grid;
}

}  // namespace

const MeterProfile& profile(Model model) { return kProfiles[static_cast<std::size_t>(model)]; }

std::span<const MeterProfile> all_profiles() { return kProfiles; }

std::optional<Model> model_from_id(std::string_view id) {
  const std::string wanted = upper_case(id);
  for (const MeterProfile& row : kProfiles) {
    if (upper_case(row.id) == wanted) return row.model;
  }
  return std::nullopt;
}

std::string_view to_string(Family family) {
  switch (family) {
    case Family::pr650:
      return "pr650";
    case Family::pr6xx:
      return "pr6xx";
    case Family::pr7xx:
      return "pr7xx";
  }
  return "unknown";
}

const Firmware* find_firmware(const MeterProfile& profile, std::string_view id) {
  const auto found = std::ranges::find(profile.firmware, id, &Firmware::id);
  return found == profile.firmware.end() ? nullptr : &*found;
}

ModelMatch match_reported_model(std::string_view text) {
  ModelMatch match{std::string(trim_blanks(text)), {}};
  std::string squeezed;
  for (const char c : upper_case(match.reported)) {
    if (c != ' ' && c != '-') squeezed += c;
  }
  std::string_view rest = squeezed;
  while (!rest.empty()) {
    const auto slash = rest.find('/');
    const std::string_view number = part_number(rest.substr(0, slash));
    for (const MeterProfile& row : kProfiles) {
      if (!number.empty() && model_number(row) == number &&
          std::find(match.candidates.begin(), match.candidates.end(), row.model) == match.candidates.end()) {
        match.candidates.push_back(row.model);
      }
    }
    if (slash == std::string_view::npos) break;
    rest.remove_prefix(slash + 1);
  }
  return match;
}

std::optional<Model> resolve_model(const ModelMatch& match, const Grid& grid) {
  if (match.candidates.size() == 1) return match.candidates.front();
  std::optional<Model> found;
  for (const Model model : match.candidates) {
    if (!fits_grid(profile(model), grid)) continue;
    if (found) return std::nullopt;
    found = model;
  }
  return found;
}

}  // namespace skinspec::drivers
