#pragma once
// The field layouts of the PR-6xx/7xx replies (private to drivers/): what each kind of field
// looks like, and the status that leads every reply. Shared by the pr6xx and pr7xx parsers.

#include <expected>
#include <optional>
#include <string_view>

#include "common/text.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx::fields {

using detail::Match;

// -?\d{1,5}: "0000", "00000", "-8", "-0008", "0001".
Match match_status(std::string_view text);
Status status_value(std::string_view text);  // of a text match_status accepted in full
// The units code: 0-3 (PR-7xx manuals) or 11-14, 111-114 (PR-655/670 manual), up to 4 digits.
Match match_units(std::string_view text);
// -?d.ddd[eE][+-]dd or with three exponent digits: "9.910e-07", "0.000e+000".
Match match_value(std::string_view text);
// The exponent digits of a value match_value accepted: 2 or 3.
int exponent_digits(std::string_view value);
// A whole number of at most 6 digits (grids, codes, milliseconds).
Match match_whole(std::string_view text);
// A CCT: a whole number right-aligned in blanks (" 3757").
Match match_cct(std::string_view text);
Match match_number(std::string_view text);         // unsigned decimal: "0.00", "60.00"
Match match_signed_number(std::string_view text);  // "0.0129", "-0.0031"
// Printable text without a comma: model names, gain labels, aperture names.
Match match_label(std::string_view text);

inline constexpr detail::FieldSpec kStatusField{match_status, "status such as 00000 or -8"};
inline constexpr detail::FieldSpec kUnitsField{match_units, "units code (0-3, 11-14, 111-114)"};
inline constexpr detail::FieldSpec kValueField{match_value, "value such as 9.910e-07"};
inline constexpr detail::FieldSpec kChromaticityField{detail::match_chromaticity, "chromaticity such as 0.4035"};
inline constexpr detail::FieldSpec kWholeField{match_whole, "whole number"};
inline constexpr detail::FieldSpec kCctField{match_cct, "colour temperature such as \" 3757\""};
inline constexpr detail::FieldSpec kNumberField{match_number, "number"};
inline constexpr detail::FieldSpec kSignedNumberField{match_signed_number, "signed number"};
inline constexpr detail::FieldSpec kLabelField{match_label, "printable label"};

// The status leading a line, up to its first comma or its end; the line's other text after it
// (without the comma), when there is a comma.
struct LeadingStatus {
  Status status;
  std::optional<std::string_view> rest;
};
std::expected<LeadingStatus, ProtocolError> leading_status(const detail::Line& line);

// The number of a field that matched in full; nothing when it does not fit a finite double.
std::optional<double> number(std::string_view text);
// The leading whole number of a field that matched in full: "201", " 3757", "16500 msec".
int whole(std::string_view text);

}  // namespace skinspec::drivers::pr6xx::fields
