#pragma once
// What differs between the Photo Research models skinspec speaks to, as data: one row per
// model (grid, exposure range, sync style, capabilities, how its replies look, byte pacing).
// Drivers and the simulator read the table instead of branching on the model.
// docs/pr6xx-protocol.md gives the sources of every value.

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::drivers {

enum class Family : std::uint8_t { pr650, pr6xx, pr7xx };
enum class Model : std::uint8_t { pr650, pr655, pr670, pr680, pr730, pr735, pr740, pr745, pr788 };

// A wavelength grid in whole nanometres, as D120 reports it.
struct Grid {
  int first_nm = 0, last_nm = 0, step_nm = 0, points = 0;
  // The points fill first..last by step exactly.
  constexpr bool consistent() const {
    return step_nm > 0 && last_nm > first_nm && (last_nm - first_nm) % step_nm == 0 &&
           points == (last_nm - first_nm) / step_nm + 1;
  }
  friend constexpr bool operator==(const Grid&, const Grid&) = default;
};

// Exposure (integration) time in ms; max_extended_ms is the limit under extended sensitivity
// (SH1), 0 where the model has none.
struct ExposureRange {
  int min_ms = 0, max_ms = 0, max_extended_ms = 0;
};

enum class SyncStyle : std::uint8_t {
  setup_field,  // the PR-650's S command, field 5
  ss_sk,        // SS0 none, SS1 auto, SS3 user with SKfff
};
enum class ErrorTable : std::uint8_t { pr650_quality, pr6xx };
// What follows " REMOTE MODE" when the meter prints it on its own.
enum class BannerEnd : std::uint8_t { none, crlf };

struct Capabilities {
  bool remote_keyword = false;      // PHOTO enters and Q leaves remote mode
  bool sensitivity = false;         // SH
  bool aperture = false;            // SF, D117
  bool smart_dark = false;          // SD
  bool trigger_poll_abort = false;  // T, P, A, V
};

// How the model prints its replies (the simulator's defaults); the parsers accept every
// variant of every model.
struct WireStyle {
  BannerEnd banner = BannerEnd::none;
  int data_status_digits = 5, setup_status_digits = 4;
  bool padded_errors = false;  // "-0008" rather than "-8"
  int data_exponent_digits = 2;
  char exponent_letter = 'e';
};

// How a firmware spells the sync-mode command: SSf as the manuals' headings and the field's
// drivers do, or SQf as the older syntax lines print it.
enum class SyncCommand : std::uint8_t { ss, sq };

// One generation of a model's firmware, named by the manual that describes it (the source ids of
// docs/pr6xx-protocol.md, lower case): the commands it knows where the generations differ. A
// model's first row is the newest; the simulator plays each (--firmware), and the drivers find
// out which one they talk to from the meter's refusals.
struct Firmware {
  std::string_view id;              // "m730": the 2009 PR-730/735 manual; --firmware of skinspec-sim
  bool trigger_poll_abort = false;  // T, P, A and V
  SyncCommand sync = SyncCommand::ss;
};

struct MeterProfile {
  Model model;
  Family family;
  std::string_view id;                               // "pr670": --model, JSON
  std::string_view name;                             // "PR-670": messages
  std::string_view d111;                             // what D111 reports ("" for the PR-650, which has no D111)
  std::optional<Grid> grid;                          // documented native grid; nullopt: unknown
  std::array<std::optional<Grid>, 2> grid_variants;  // other grids the sources give for it
  std::optional<Grid> simulator_grid;                // the documented grid, or a derived one
  ExposureRange exposure;
  SyncStyle sync;
  int sync_min_hz, sync_max_hz;
  Capabilities caps;
  WireStyle wire;
  ErrorTable errors;
  std::chrono::milliseconds pacing;    // between the bytes of a command
  std::string_view serial;             // the simulator's D110
  std::span<const Firmware> firmware;  // newest first; empty for the PR-650
};

const MeterProfile& profile(Model model);
std::span<const MeterProfile> all_profiles();             // in enum order
std::optional<Model> model_from_id(std::string_view id);  // "pr670" -> Model::pr670 (case-insensitive)
std::string_view to_string(Family family);                // "pr650", "pr6xx", "pr7xx"
// The model's firmware generation `id` ("m730"); nullptr when the model has none of that name.
const Firmware* find_firmware(const MeterProfile& profile, std::string_view id);

// The models a D111 text names. Case, blanks, hyphens and a leading "PR" are ignored, a
// '/'-list names several ("PR-730/735"), and letters after the number are a variant of the
// same model ("PR-680L").
struct ModelMatch {
  std::string reported;           // the text as given, blanks around it removed
  std::vector<Model> candidates;  // empty: no model skinspec knows
};
ModelMatch match_reported_model(std::string_view text);

// The one model a match and the meter's D120 grid point to: a single candidate, or the
// candidate whose documented grid (or a variant of it) is `grid`. Nothing when no candidate or
// several fit.
std::optional<Model> resolve_model(const ModelMatch& match, const Grid& grid);

}  // namespace skinspec::drivers
