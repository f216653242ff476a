// PR-650 reply parsers. They accept every variant the sources disagree on (header H1 or H2,
// 'E' or 'e', CR, LF or CR LF, blank lines and '>' prompts around a reply) but hold the
// meter's fixed field widths strictly: a dropped or flipped byte must give an error, never a
// plausible wrong number.

#include <array>
#include <span>
#include <utility>

#include <fmt/format.h>

#include "pr650/protocol_text.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650 {

namespace {

using detail::Line;
using detail::LineSplitter;
using detail::Match;
using detail::quoted;
using Kind = ProtocolError::Kind;

std::unexpected<ProtocolError> fail(Kind kind, std::size_t line, std::string_view message) {
  return std::unexpected(detail::make_error(kind, line, message));
}

// ---- Lines around a reply ---------------------------------------------------------------

// The first line of a reply that holds more than blanks and prompts.
std::expected<Line, ProtocolError> first_line(std::string_view reply, LineSplitter& lines) {
  if (auto line = lines.next_content()) return *line;
  if (reply.find_first_of("\r\n") == std::string_view::npos) {
    return fail(Kind::truncated, 0, "the reply is empty");
  }
  return fail(Kind::garbled, 0, "the reply holds only blank lines and prompts");
}

// After a reply's last line only blank lines and '>' prompts may follow.
std::optional<ProtocolError> check_tail(LineSplitter& lines) {
  while (auto line = lines.next()) {
    if (!detail::is_prompt_or_blank(line->text)) {
      return detail::make_error(Kind::surplus, line->number, "unexpected bytes after the reply: " + quoted(line->text));
    }
  }
  return std::nullopt;
}

// A one-line reply must end with its line end and have nothing but noise after it.
std::optional<ProtocolError> check_end(const Line& line, LineSplitter& rest) {
  if (!line.terminated) {
    return detail::make_error(Kind::truncated, line.number, "the reply has no line end");
  }
  return check_tail(rest);
}

// ---- Comma-separated fields -------------------------------------------------------------

enum class FieldKind { quality, units, value, chromaticity, integer, number, signed_number };

struct FieldSpec {
  FieldKind kind;
  const char* name;
};

bool all_digits(std::string_view text) {
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

Match match_field(FieldKind kind, std::string_view text) {
  switch (kind) {
    case FieldKind::quality:
      return detail::match_template(text, "dd");
    case FieldKind::units:
      return detail::match_template(text, "d");
    case FieldKind::value:
      return detail::match_template(text, detail::kValueTemplate);
    case FieldKind::chromaticity:
      return detail::match_chromaticity(text);
    case FieldKind::integer:
      if (!all_digits(text) || text.size() > 9) return Match::mismatch;
      return text.empty() ? Match::prefix : Match::full;
    case FieldKind::number:
      return detail::match_decimal(text, false);
    case FieldKind::signed_number:
      return detail::match_decimal(text, true);
  }
  return Match::mismatch;
}

std::vector<std::string_view> split_fields(std::string_view text) {
  std::vector<std::string_view> fields;
  for (;;) {
    const auto comma = text.find(',');
    fields.push_back(text.substr(0, comma));
    if (comma == std::string_view::npos) return fields;
    text.remove_prefix(comma + 1);
  }
}

// Checks one field. A field that could still be completed is cut short when nothing follows
// it on the line; in the middle of a line a short field is a wrong one.
std::optional<ProtocolError> check_field(const FieldSpec& spec, std::string_view text, std::size_t index, bool last,
                                         const Line& line) {
  const Match match = match_field(spec.kind, text);
  if (match == Match::prefix && last) {
    return detail::make_error(Kind::truncated, line.number,
                              fmt::format("field {} ({}) is cut short: {}", index + 1, spec.name, quoted(text)));
  }
  if (match != Match::full) {
    return detail::make_error(Kind::garbled, line.number,
                              fmt::format("field {} is not a {}: {}", index + 1, spec.name, quoted(text)));
  }
  return std::nullopt;
}

// The number in a field that matched its layout; nothing when it does not fit a double.
std::optional<double> field_number(FieldKind kind, std::string_view text) {
  if (kind == FieldKind::quality || kind == FieldKind::units || kind == FieldKind::integer) {
    return detail::digits_value(text);
  }
  return detail::to_double(text);
}

// The numbers of a line made of exactly the fields in `specs`.
std::expected<std::vector<double>, ProtocolError> parse_fields(const Line& line, std::span<const FieldSpec> specs) {
  const auto fields = split_fields(line.text);
  std::vector<double> numbers;
  numbers.reserve(specs.size());
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (i >= fields.size()) {
      return fail(Kind::truncated, line.number,
                  fmt::format("{} of {} fields: {}", fields.size(), specs.size(), quoted(line.text)));
    }
    const bool last = i + 1 == fields.size();
    if (auto error = check_field(specs[i], fields[i], i, last, line)) return std::unexpected(*error);
    const auto number = field_number(specs[i].kind, fields[i]);
    if (!number) {
      return fail(Kind::garbled, line.number, fmt::format("field {} is out of range: {}", i + 1, quoted(fields[i])));
    }
    if (specs[i].kind == FieldKind::units && *number > 2) {
      return fail(Kind::garbled, line.number, fmt::format("units code {} is not 0, 1 or 2", quoted(fields[i])));
    }
    numbers.push_back(*number);
  }
  if (fields.size() > specs.size()) {
    return fail(Kind::surplus, line.number, fmt::format("more than {} fields: {}", specs.size(), quoted(line.text)));
  }
  return numbers;
}

constexpr FieldSpec kQuality{FieldKind::quality, "two-digit quality code"};
constexpr FieldSpec kUnits{FieldKind::units, "units code"};
constexpr FieldSpec kValue{FieldKind::value, "value such as 5.882E-05"};
constexpr FieldSpec kChromaticity{FieldKind::chromaticity, "chromaticity such as .3355"};
constexpr FieldSpec kNumber{FieldKind::number, "number"};
constexpr FieldSpec kSignedNumber{FieldKind::signed_number, "signed number"};
constexpr FieldSpec kInteger{FieldKind::integer, "whole number"};

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
  switch (detail::match_template(line.text, detail::kDataLineTemplate)) {
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
    if (detail::match_template(line->text, detail::kDataLineTemplate) != Match::full) {
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
    if (detail::match_template(line->text, detail::kDataLineTemplate) == Match::full) {
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
  if (line->text.size() > 3 || !all_digits(line->text)) {
    return fail(Kind::garbled, line->number, "expected a status such as \"000\", got " + quoted(line->text));
  }
  if (auto error = check_tail(lines)) return std::unexpected(*error);
  return detail::digits_value(line->text);
}

std::expected<int, ProtocolError> parse_setup_reply(std::string_view reply) {
  LineSplitter lines(reply);
  const auto line = first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  if (line->text.size() > 2 || !all_digits(line->text)) {
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
  for (const char c : line->text) {
    if (c < 0x20 || c > 0x7e) {
      return fail(Kind::garbled, line->number, "the serial number holds a non-printable byte: " + quoted(line->text));
    }
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
