// PR-650 reply parsers. They accept every variant the sources disagree on (header H1 or H2,
// 'E' or 'e', CR, LF or CR LF, blank lines and '>' prompts around a reply) but hold the
// meter's fixed field widths strictly: a dropped or flipped byte must give an error, never a
// plausible wrong number.

#include <array>
#include <span>
#include <utility>

#include <fmt/format.h>

#include "common/text.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650 {

namespace {

using detail::fail;
using detail::Line;
using detail::LineSplitter;
using detail::Match;
using detail::quoted;
using Kind = ProtocolError::Kind;

// A data line of the spectral report: wavelength and value.
constexpr std::string_view kDataLineTemplate = "dddd.,d.dddxsdd";  // 0380.,5.882E-05

// ---- Comma-separated fields -------------------------------------------------------------

using detail::check_end;
using detail::check_tail;
using detail::FieldSpec;
using detail::first_line;

Match match_quality(std::string_view text) { return detail::match_template(text, "dd"); }

// 0 radiance or luminance, 1 irradiance or illuminance, 2 uncalibrated.
Match match_units(std::string_view text) {
  const Match match = detail::match_template(text, "d");
  return match == Match::full && text[0] > '2' ? Match::mismatch : match;
}

Match match_value(std::string_view text) { return detail::match_template(text, detail::kValueTemplate); }

Match match_integer(std::string_view text) {
  if (!detail::all_digits(text) || text.size() > 9) return Match::mismatch;
  return text.empty() ? Match::prefix : Match::full;
}

Match match_number(std::string_view text) { return detail::match_decimal(text, false); }
Match match_signed_number(std::string_view text) { return detail::match_decimal(text, true); }

// The numbers of a line made of exactly the fields in `specs`.
std::expected<std::vector<double>, ProtocolError> parse_fields(const Line& line, std::span<const FieldSpec> specs) {
  const auto fields = detail::match_fields(line, specs);
  if (!fields) return std::unexpected(fields.error());
  std::vector<double> numbers;
  numbers.reserve(specs.size());
  for (std::size_t i = 0; i < fields->size(); ++i) {
    const auto number = detail::to_double((*fields)[i]);
    if (!number) {
      return fail(Kind::garbled, line.number, fmt::format("field {} is out of range: {}", i + 1, quoted((*fields)[i])));
    }
    numbers.push_back(*number);
  }
  return numbers;
}

constexpr FieldSpec kQuality{match_quality, "two-digit quality code"};
constexpr FieldSpec kUnits{match_units, "units code 0, 1 or 2"};
constexpr FieldSpec kValue{match_value, "value such as 5.882E-05"};
constexpr FieldSpec kChromaticity{detail::match_chromaticity, "chromaticity such as .3355"};
constexpr FieldSpec kNumber{match_number, "number"};
constexpr FieldSpec kSignedNumber{match_signed_number, "signed number"};
constexpr FieldSpec kInteger{match_integer, "whole number"};

constexpr std::array kReport1{kQuality, kUnits, kValue, kChromaticity, kChromaticity};
constexpr std::array kReport2{kQuality, kUnits, kValue, kValue, kValue};
// CCT and deviation widths are unknown, so any decimal layout is accepted there.
constexpr std::array kReport4{kQuality, kUnits, kValue, kNumber, kSignedNumber};
constexpr std::array kReport6{kQuality, kUnits, kValue, kChromaticity, kChromaticity, kChromaticity, kChromaticity};
constexpr std::array kSpectralStatus{kQuality, kUnits};
constexpr std::array kConfiguration{kInteger, kNumber, kNumber, kNumber, kNumber};

std::span<const FieldSpec> colorimetric_layout(int report) {
  switch (report) {
    case 1:
    case 3:
      return kReport1;  // Y,x,y and Y,u',v' share a layout
    case 2:
      return kReport2;
    case 4:
      return kReport4;
    case 6:
      return kReport6;
    default:
      return {};
  }
}

// ---- Spectral report --------------------------------------------------------------------

struct DataPoint {
  int wavelength_nm;
  double value;
};

std::expected<DataPoint, ProtocolError> parse_data_line(const Line& line) {
  switch (detail::match_template(line.text, kDataLineTemplate)) {
    case Match::full:
      break;
    case Match::prefix:
      return fail(Kind::truncated, line.number, "data line cut short: " + quoted(line.text));
    case Match::mismatch:
      return fail(Kind::garbled, line.number,
                  "expected a data line such as \"0380.,5.882E-05\", got " + quoted(line.text));
  }
  if (!line.terminated) return fail(Kind::truncated, line.number, "data line has no line end");
  return DataPoint{detail::digits_value(line.text.substr(0, 4)), detail::to_double(line.text.substr(6)).value_or(0)};
}

constexpr int grid_nm(int index) { return static_cast<int>(kFirstNm + kStepNm * index); }
constexpr int kLastNm = grid_nm(kSpectralPoints - 1);

// When a data line breaks the grid but the report still ends at 780 nm, lines were lost or
// repeated, and the count is what is wrong. Returns the total number of data lines then.
std::optional<int> count_if_ending_at_last(LineSplitter rest, int lines_so_far) {
  int count = lines_so_far;
  int last_nm = -1;
  while (auto line = rest.next_non_empty()) {
    if (detail::match_template(line->text, kDataLineTemplate) != Match::full) {
      if (!detail::is_prompt_or_blank(line->text)) return std::nullopt;
      continue;
    }
    ++count;
    last_nm = detail::digits_value(line->text.substr(0, 4));
  }
  if (last_nm != kLastNm || count == kSpectralPoints) return std::nullopt;
  return count;
}

std::optional<ProtocolError> off_grid_error(const Line& line, int index, int found_nm, const LineSplitter& rest) {
  const int expected_nm = grid_nm(index);
  if (auto count = count_if_ending_at_last(rest, index + 1)) {
    return detail::make_error(Kind::wrong_count, line.number,
                              fmt::format("{} data lines where {} are expected ({} nm where {} nm should be)", *count,
                                          kSpectralPoints, found_nm, expected_nm));
  }
  return detail::make_error(Kind::wrong_wavelength, line.number,
                            fmt::format("{} nm where {} nm should be", found_nm, expected_nm));
}

std::optional<ProtocolError> parse_spectral_header(std::string_view reply, LineSplitter& lines,
                                                   SpectralReport& report) {
  const auto status_line = first_line(reply, lines);
  if (!status_line) return status_line.error();
  const auto status = parse_fields(*status_line, kSpectralStatus);
  if (!status) return status.error();
  if (!status_line->terminated) {
    return detail::make_error(Kind::truncated, status_line->number, "the header has no line end");
  }
  report.quality = static_cast<int>((*status)[0]);
  report.units = static_cast<int>((*status)[1]);

  const auto integrated = lines.next_non_empty();
  if (!integrated) {
    return detail::make_error(Kind::truncated, lines.lines_read() + 1, "the reply ends before the integrated value");
  }
  const auto value = parse_fields(*integrated, std::span(&kValue, 1));
  if (!value) return value.error();
  if (!integrated->terminated) {
    return detail::make_error(Kind::truncated, integrated->number, "the integrated value has no line end");
  }
  report.integrated = (*value)[0];
  return std::nullopt;
}

std::optional<ProtocolError> parse_spectral_data(LineSplitter& lines, SpectralReport& report) {
  report.wavelength_nm.reserve(kSpectralPoints);
  report.values.reserve(kSpectralPoints);
  for (int i = 0; i < kSpectralPoints; ++i) {
    const auto line = lines.next_non_empty();
    if (!line) {
      return detail::make_error(Kind::truncated, lines.lines_read() + 1,
                                fmt::format("the reply ends after {} of {} data lines", i, kSpectralPoints));
    }
    const auto point = parse_data_line(*line);
    if (!point) return point.error();
    if (point->wavelength_nm != grid_nm(i)) return off_grid_error(*line, i, point->wavelength_nm, lines);
    report.wavelength_nm.push_back(point->wavelength_nm);
    report.values.push_back(point->value);
  }
  return std::nullopt;
}

// After the 780 nm line: another data line means too many lines, anything else is surplus.
std::optional<ProtocolError> check_spectral_tail(LineSplitter& lines) {
  while (auto line = lines.next()) {
    if (detail::is_prompt_or_blank(line->text)) continue;
    if (detail::match_template(line->text, kDataLineTemplate) == Match::full) {
      return detail::make_error(Kind::wrong_count, line->number,
                                fmt::format("more than {} data lines", kSpectralPoints));
    }
    return detail::make_error(Kind::surplus, line->number,
                              "unexpected bytes after the 780 nm line: " + quoted(line->text));
  }
  return std::nullopt;
}

}  // namespace

std::expected<int, ProtocolError> parse_status(std::string_view reply) {
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  // "000", "00" and "0" are all in use. Unlike other replies a missing line end is accepted:
  // a status cut short still reads the same.
  if (line->text.size() > 3 || !detail::all_digits(line->text)) {
    return fail(Kind::garbled, line->number, "expected a status such as \"000\", got " + quoted(line->text));
  }
  if (auto error = check_tail(lines)) return std::unexpected(*error);
  return detail::digits_value(line->text);
}

std::expected<int, ProtocolError> parse_setup_reply(std::string_view reply) {
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  if (line->text.size() > 2 || !detail::all_digits(line->text)) {
    return fail(Kind::garbled, line->number, "expected a setup reply such as \"00\", got " + quoted(line->text));
  }
  if (auto error = check_end(*line, lines)) return std::unexpected(*error);
  return detail::digits_value(line->text);
}

std::expected<FlickerReply, ProtocolError> parse_flicker(std::string_view reply) {
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  constexpr std::array kFlicker{kQuality, kNumber};
  const bool has_frequency = line->text.find(',') != std::string_view::npos;
  // A failed F may give the quality code alone: there is no frequency to report then.
  const auto fields = parse_fields(*line, std::span(kFlicker).first(has_frequency ? 2 : 1));
  if (!fields) return std::unexpected(fields.error());
  FlickerReply result{static_cast<int>((*fields)[0]), has_frequency ? (*fields)[1] : 0};
  if (!has_frequency && result.quality == 0) {
    return fail(Kind::truncated, line->number, "the reply ends before the frequency");
  }
  if (auto error = check_end(*line, lines)) return std::unexpected(*error);
  return result;
}

std::expected<ColorimetricReport, ProtocolError> parse_colorimetric(int report, std::string_view reply) {
  const auto layout = colorimetric_layout(report);
  if (layout.empty()) {
    return fail(Kind::garbled, 0, fmt::format("report {} is not a colorimetric report", report));
  }
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  auto fields = parse_fields(*line, layout);
  if (!fields) return std::unexpected(fields.error());
  if (auto error = check_end(*line, lines)) return std::unexpected(*error);
  ColorimetricReport result;
  result.report = report;
  result.quality = static_cast<int>((*fields)[0]);
  result.units = static_cast<int>((*fields)[1]);
  result.values.assign(fields->begin() + 2, fields->end());
  return result;
}

std::expected<SpectralReport, ProtocolError> parse_spectral(std::string_view reply) {
  LineSplitter lines(reply);
  SpectralReport report;
  if (auto error = parse_spectral_header(reply, lines, report)) return std::unexpected(*error);
  if (auto error = parse_spectral_data(lines, report)) return std::unexpected(*error);
  if (auto error = check_spectral_tail(lines)) return std::unexpected(*error);
  return report;
}

std::expected<std::string, ProtocolError> parse_serial_number(std::string_view reply) {
  constexpr std::size_t kSerialLength = 8;
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  if (!detail::is_printable(line->text)) {
    return fail(Kind::garbled, line->number, "the serial number holds a non-printable byte: " + quoted(line->text));
  }
  std::string_view serial = line->text.substr(0, kSerialLength);
  const std::string_view after = line->text.substr(serial.size());
  if (after.find_first_not_of(' ') != std::string_view::npos) {
    return fail(Kind::surplus, line->number, "more than 8 characters in the serial number: " + quoted(line->text));
  }
  while (!serial.empty() && serial.back() == ' ') serial.remove_suffix(1);
  if (serial.empty()) return fail(Kind::garbled, line->number, "the serial number is empty");
  if (auto error = check_end(*line, lines)) return std::unexpected(*error);
  return std::string(serial);
}

std::expected<SpectralConfiguration, ProtocolError> parse_spectral_configuration(std::string_view reply) {
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  const auto fields = parse_fields(*line, kConfiguration);
  if (!fields) return std::unexpected(fields.error());
  if (auto error = check_end(*line, lines)) return std::unexpected(*error);
  const auto& f = *fields;
  return SpectralConfiguration{static_cast<int>(f[0]), f[1], f[2], f[3], f[4]};
}

}  // namespace skinspec::drivers::pr650
