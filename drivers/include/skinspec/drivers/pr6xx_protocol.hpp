#pragma once
// The language of the PR-655/670/680 and PR-7xx as pure functions: commands to bytes, reply
// bytes to typed values, and (for the simulator and tests) typed values to reply bytes. No I/O,
// no clock. docs/pr6xx-protocol.md summarises it; every variant the sources disagree on is
// accepted: " REMOTE MODE" with or without a line end or glued to the next reply, 4- or
// 5-digit statuses, "-8" or "-0008", 2- or 3-digit exponents, 'e' or 'E', CR, LF or CR LF.
//
// Parsers take the bytes of one reply after split_banner and strip_echo. A meter's negative
// status is a valid reply (its data fields are then empty): what it means is the driver's
// business, classify() names it. ProtocolError is for bytes the meter cannot have sent.

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/protocol_error.hpp"

namespace skinspec::drivers::pr6xx {

// ---- Commands -----------------------------------------------------------------------------

inline constexpr std::string_view kRemoteKeyword = "PHOTO";  // no terminator; case-sensitive
inline constexpr std::string_view kQuit = "Q";               // no terminator, no reply
inline constexpr std::string_view kBanner = " REMOTE MODE";  // PHOTO's reply, leading blank

struct CommandStyle {
  char terminator = '\r';  // the manuals' CR; LF is accepted by meters in the field
};

std::string format_command(std::string_view body, const CommandStyle& style = {});  // upper case + terminator
std::string format_report(int code, const CommandStyle& style = {});                // "D5\r", "D110\r", "D120\r"
std::string format_measure(int code, const CommandStyle& style = {});               // "M5\r"
// "SE0\r" is adaptive; below 100000 ms five digits ("SE00250\r"), above plain ("SE120000\r").
std::string format_exposure(int ms, const CommandStyle& style = {});
std::string format_averages(int cycles, const CommandStyle& style = {});  // "SN01\r" ... "SN99\r"
enum class SyncMode { none = 0, automatic = 1, user = 3 };
// "SS0\r" "SS1\r" "SS3\r"; "SQ0\r" ... as the older syntax lines spell it.
std::string format_sync_mode(SyncMode mode, const CommandStyle& style = {}, SyncCommand spelling = SyncCommand::ss);
std::string format_sync_frequency(int hz, const CommandStyle& style = {});      // "SK060\r" (20-400 Hz)
std::string format_sensitivity(bool extended, const CommandStyle& style = {});  // "SH0\r" / "SH1\r"
std::string format_aperture(int code, const CommandStyle& style = {});          // "SF1\r" (code from D117)
std::string format_units(bool si, const CommandStyle& style = {});              // "SU1\r" / "SU0\r"
std::string format_flicker(const CommandStyle& style = {});                     // "F\r"

// A command is whole (for recordings and the simulator's framing) once it ends in CR or LF,
// or when it is exactly PHOTO or Q.
bool command_complete(std::string_view pending);

// ---- Framing ------------------------------------------------------------------------------

// What leads the received bytes: the banner (with or without its blank), the line end after it
// if any, and the bytes after it, which may be the next reply glued to it.
struct BannerSplit {
  enum class Found { none, partial, whole } found = Found::none;  // partial: " REM" so far, wait
  bool line_end = false;                                          // CR, LF or CR LF followed it
  std::string_view rest;                                          // the bytes after it (all of `received` when none)
};
BannerSplit split_banner(std::string_view received);

// The reply with an echo of `command` and '>' prompts around it removed (after E; never sent).
std::string_view strip_echo(std::string_view received, std::string_view command);

// How a reply ends:
//   line:     one line;
//   spectral: a status line with a code other than 0 is whole by itself; otherwise the header
//             and `points` data lines (D120's count);
//   listing:  one item per line (D117), ended by the meter falling silent.
enum class ReplyShape { line, spectral, listing };
// The bytes of the first whole reply of that shape (through its last line end), or 0 while it
// is incomplete. For a listing: the whole lines so far, the caller waits for silence.
std::size_t reply_size(ReplyShape shape, std::string_view received, int points = 0);

// ---- Status and meter error codes ---------------------------------------------------------

// The status of a command the meter does not know (M655 to M7XX alike): what an older firmware
// answers to a command a newer one added.
inline constexpr int kIllegalCommand = -1000;

struct Status {
  int code = 0;    // 0 OK, negative an error, 1 busy (P and S... on the PR-7xx)
  int digits = 0;  // as printed, without sign: 4 for "0000", 5 for "00000", 1 for "-8"
  friend bool operator==(const Status&, const Status&) = default;
};

// A reply that is a status alone: setup commands, I, and any error. "0000", "00000", "-8",
// "-0008", "0001", "-1035".
std::expected<Status, ProtocolError> parse_status(std::string_view reply);

enum class ErrorClass {
  ok,
  too_dark,             // -8 weak light
  overload,             // -2
  sync,                 // -3 cannot sync, -9 sync error, -10 cannot auto-sync
  source_not_constant,  // -1
  adaptive,             // -4 adaptive-mode error
  unstable_source,      // -12 adaptive timeout
  command_rejected,     // -1000 ... -1035: a command the meter could not parse or apply
  no_data,              // -2000: no such report, or no measurement yet
  busy,                 // 1: a PR-7xx still measuring
  unknown,
};
ErrorClass classify(int code);
std::string_view to_string(ErrorClass error_class);  // "too_dark", ...
// "weak light (-8)", "illegal command (-1000)", "parse error (-1017)", "unknown error code -77".
std::string error_message(int code);

// ---- Identity and configuration reports ---------------------------------------------------

// D110 (serial), D111 (model), D114 (firmware): "00000,PR-670" -> {0, "PR-670"}.
struct TextReport {
  Status status;
  std::string text;  // trailing blanks removed; empty with a non-zero status
};
std::expected<TextReport, ProtocolError> parse_text_report(std::string_view reply);

// D120: "00000,201,0.00,380,780,2,256,7,247": points, bandwidth, first, last, step, and (when
// present) the pixel count and the first and last usable pixel.
struct HardwareConfiguration {
  Status status;
  Grid grid;  // consistent() whenever status is 0
  double bandwidth_nm = 0;
  std::optional<int> pixels, first_pixel, last_pixel;
};
std::expected<HardwareConfiguration, ProtocolError> parse_hardware_configuration(std::string_view reply);

// F: "0000,60.00 Hertz (Period = 16.67 milliseconds)" -> 60; "-3" -> no frequency.
struct FlickerReply {
  Status status;
  std::optional<double> hz;
};
std::expected<FlickerReply, ProtocolError> parse_flicker(std::string_view reply);

// D117, one line per aperture: "00000,1,1/2 deg,0.00".
struct Aperture {
  int code = 0;
  std::string name;
  double bandwidth_nm = 0;
  friend bool operator==(const Aperture&, const Aperture&) = default;
};
struct ApertureList {
  Status status;  // of the first line; a non-zero status comes alone
  std::vector<Aperture> apertures;
};
std::expected<ApertureList, ProtocolError> parse_apertures(std::string_view reply);

// D13: "00000,Fast,16500 msec": the gain label and the exposure actually used.
struct ExposureReport {
  Status status;
  std::string gain;
  int exposure_ms = 0;
};
std::expected<ExposureReport, ProtocolError> parse_exposure_report(std::string_view reply);

// ---- Measurement reports ------------------------------------------------------------------

// Reports 1 (Y,x,y), 2 (X,Y,Z), 3 (Y,u',v'), 4 (Y,CCT,deviation) and 6 (Y,x,y,u',v').
struct ColorimetricReport {
  int report = 0;
  Status status;
  int units = 0;  // 0-3, 11-14 or 111-114, as printed
  std::vector<double> values;
};
std::expected<ColorimetricReport, ProtocolError> parse_colorimetric(int report, std::string_view reply);

// M5/D5: a header "qqqqq,U,peak,integrated,photon" and one line per wavelength, which must be
// exactly the `expected` grid (D120's).
struct SpectralReport {
  Status status;  // not 0: no data (the code alone, or a header whose data are ignored)
  int units = 0;
  double peak_nm = 0, integrated = 0, integrated_photon = 0;
  std::vector<int> wavelength_nm;
  std::vector<double> values;  // per nm, as printed
  int exponent_digits = 0;     // of the data lines: 2 or 3, the same on every line
};
std::expected<SpectralReport, ProtocolError> parse_spectral(std::string_view reply, const Grid& expected);

// ---- Reply formatting (what a meter sends; for the simulator and tests) -------------------

struct ReplyStyle {
  int data_status_digits = 5, setup_status_digits = 4;
  bool padded_errors = false;
  int data_exponent_digits = 2;
  char exponent = 'e';
  BannerEnd banner = BannerEnd::none;
};
ReplyStyle reply_style(const WireStyle& wire);

// "d.ddde-dd" (or three exponent digits), negative values with a '-'. With two digits a
// magnitude below 1e-99 prints as 0.000e+00 and one of 1e+100 or more as 9.999e+99.
std::string format_value(double value, int exponent_digits = 2, char exponent = 'e');
std::string format_banner(const ReplyStyle& style);                              // " REMOTE MODE" [+ "\r\n"]
std::string format_setup_status(int code, const ReplyStyle& style);              // "0000\r\n"; errors as format_error
std::string format_error(int code, const ReplyStyle& style);                     // "-8\r\n" / "-0008\r\n"
std::string format_text_report(std::string_view text, const ReplyStyle& style);  // "00000,PR-670\r\n"
std::string format_hardware_configuration(const HardwareConfiguration& configuration, const ReplyStyle& style);
std::string format_flicker_reply(const FlickerReply& reply, const ReplyStyle& style);
std::string format_apertures_reply(const std::vector<Aperture>& apertures, const ReplyStyle& style);
std::string format_exposure_report(const ExposureReport& report, const ReplyStyle& style);
std::string format_colorimetric_reply(const ColorimetricReport& report, const ReplyStyle& style);  // CCT " 3757"
// The header's peak field always has three exponent digits, as every manual prints it.
std::string format_spectral_reply(const SpectralReport& report, const ReplyStyle& style);

}  // namespace skinspec::drivers::pr6xx
