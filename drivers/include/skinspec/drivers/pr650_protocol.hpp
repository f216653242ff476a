#pragma once
// The PR-650's RS-232 protocol as pure functions: commands to bytes, reply bytes to typed
// values, and (for the simulator) typed values to reply bytes. No I/O, no clock.
// docs/pr650-protocol.md summarises the protocol; every variant the sources disagree on is
// accepted: header on one line or two (H1 "qq,U\r<value>\r\n" / H2 "qq,U\r\n<value>\r\n"),
// 'E' or 'e' exponents, CR, LF or CRLF line ends, echo of the command with a '>' prompt.

#include <array>
#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::drivers::pr650 {

// The native spectral grid: 380-780 nm every 4 nm.
inline constexpr int kSpectralPoints = 101;
inline constexpr double kFirstNm = 380, kStepNm = 4;

// ---- Quality codes (manual p. B-30) -------------------------------------------------------

// The message of a quality code; "unknown quality code NN" for codes the manual does not list.
std::string quality_message(int code);
// Every code the manual lists, in ascending order.
const std::vector<int>& known_quality_codes();
inline bool is_sync_failure(int code) { return code == 7 || code == 8 || code == 20; }
inline bool is_low_light(int code) { return code == 10 || code == 18; }
inline bool is_overload(int code) { return code == 19; }

// ---- Commands -----------------------------------------------------------------------------

struct CommandStyle {
  char terminator = '\n';  // LF (most drivers) or CR
  bool upper_case = false;
};

// The 8 fields of the S command.
struct Setup {
  int primary_accessory = 1;                   // 1-12; 1 = MS-75 objective
  std::array<std::optional<int>, 3> addons{};  // 2-12 or absent
  enum class Sync { none, last_measured, frequency } sync = Sync::none;
  double sync_hz = 0;      // 40-250 Hz with Sync::frequency
  int integration_ms = 0;  // 10-6000, or 0 = adaptive
  int averages = 1;        // 1-99
  bool si_units = true;    // cd/m2 and lux rather than fL and fc
};

std::string format_backlight(int level, const CommandStyle& style = {});       // B0-B3
std::string format_setup(const Setup& setup, const CommandStyle& style = {});  // S...
std::string format_flicker(const CommandStyle& style = {});                    // F
std::string format_measure(int report, const CommandStyle& style = {});        // M0-M6
std::string format_report(int report, const CommandStyle& style = {});         // D1-D6, D110, D120, D201

// ---- Replies ------------------------------------------------------------------------------

struct ProtocolError {
  enum class Kind {
    truncated,         // the reply stopped before it was complete
    garbled,           // bytes that cannot be what the meter sends
    surplus,           // more than the reply should hold
    wrong_count,       // a spectral report without exactly 101 data lines
    wrong_wavelength,  // a data line for an unexpected wavelength
  };
  Kind kind;
  std::string message;
  std::size_t line = 0;  // 1-based line of the reply at fault, 0 when the whole reply is
};

// How a reply ends, so that a reader knows when it has all of it.
enum class ReplyShape { line, spectral };
ReplyShape reply_shape_of_measure(int report);  // M5 gives a spectral report, others a line
ReplyShape reply_shape_of_report(int report);   // D5 likewise
// True once `received` holds a whole reply of that shape (after any echo and prompt).
bool reply_complete(ReplyShape shape, std::string_view received);
// The bytes of the first whole reply of that shape in `received` (through its last line end),
// or 0 while it is not complete: what follows belongs to something else.
std::size_t reply_size(ReplyShape shape, std::string_view received);

// The reply with a leading echo of `command` and any '>' prompts removed.
std::string_view strip_echo(std::string_view reply, std::string_view command);

// "000" after B and M0 (also "00" and "0"); the status as an integer.
std::expected<int, ProtocolError> parse_status(std::string_view reply);
// The S command's reply (report 201): 0 = accepted, 1-8 = first invalid field, 50 = accessory.
std::expected<int, ProtocolError> parse_setup_reply(std::string_view reply);
std::string setup_reply_message(int code);

struct FlickerReply {
  int quality = 0;
  double frequency_hz = 0;
};
std::expected<FlickerReply, ProtocolError> parse_flicker(std::string_view reply);

// Reports 1-4 and 6: quality, units code, then the report's values (1: Y,x,y; 2: X,Y,Z;
// 3: Y,u',v'; 4: Y,CCT,deviation; 6: Y,x,y,u',v').
struct ColorimetricReport {
  int report = 0;
  int quality = 0;
  int units = 0;  // 0 luminance, 1 illuminance, 2 uncalibrated
  std::vector<double> values;
};
std::expected<ColorimetricReport, ProtocolError> parse_colorimetric(int report, std::string_view reply);

enum class HeaderVariant { h1_bare_cr, h2_two_lines };

struct SpectralReport {
  int quality = 0;
  int units = 0;                      // 0 radiance W/(sr m2 nm), 1 irradiance, 2 uncalibrated
  double integrated = 0;              // the header's integrated value
  std::vector<double> wavelength_nm;  // 380, 384, ..., 780
  std::vector<double> values;         // per nm, as the meter prints them
};
std::expected<SpectralReport, ProtocolError> parse_spectral(std::string_view reply);

// D110: the first 8 characters, trailing blanks removed.
std::expected<std::string, ProtocolError> parse_serial_number(std::string_view reply);

struct SpectralConfiguration {
  int points = 0;
  double bandwidth_nm = 0, first_nm = 0, last_nm = 0, step_nm = 0;
};
std::expected<SpectralConfiguration, ProtocolError> parse_spectral_configuration(std::string_view reply);

// ---- Reply formatting (what a meter sends; used by the simulator and by tests) -------------

struct ReplyStyle {
  HeaderVariant header = HeaderVariant::h1_bare_cr;
  char exponent = 'E';
};

// "d.dddEsdd": the 9-character field of every value (non-negative values only, as the meter).
std::string format_value(double value, char exponent = 'E');
std::string format_status_reply(int status);                  // "000\r\n"
std::string format_setup_reply(int code);                     // "00\r\n"
std::string format_flicker_reply(const FlickerReply& reply);  // "00,60.02\r\n"
std::string format_colorimetric_reply(const ColorimetricReport& report, const ReplyStyle& style = {});
std::string format_spectral_reply(const SpectralReport& report, const ReplyStyle& style = {});
std::string format_serial_number_reply(std::string_view serial);
std::string format_spectral_configuration_reply(const SpectralConfiguration& configuration);

}  // namespace skinspec::drivers::pr650
