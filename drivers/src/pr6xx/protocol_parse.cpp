// PR-6xx/7xx one-line and listing replies: statuses, identity and configuration reports, the
// flicker frequency and the colorimetric reports. The spectral report is in
// protocol_spectral.cpp. A status other than 0 is a valid reply whose data are empty; a status
// of 0 must come with every field of its layout, each in its exact shape.

#include <array>
#include <span>
#include <utility>

#include <fmt/format.h>

#include "pr6xx/fields.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx {

namespace {

using detail::fail;
using detail::FieldSpec;
using detail::Line;
using detail::LineSplitter;
using detail::Match;
using detail::quoted;
using Kind = ProtocolError::Kind;

// The fields of a data line, the status first. `fields` is empty when the status is not 0.
struct DataLine {
  Status status;
  std::vector<std::string_view> fields;
};

// Checks a line against `specs` (whose first is the status) when its status is 0; a line with
// another status is whole by its status alone.
std::expected<DataLine, ProtocolError> read_data_line(const Line& line, std::span<const FieldSpec> specs) {
  const auto leading = fields::leading_status(line);
  if (!leading) return std::unexpected(leading.error());
  if (leading->status.code != 0) return DataLine{leading->status, {}};
  if (!leading->rest) {
    const bool cut = !line.terminated;
    return fail(cut ? Kind::truncated : Kind::garbled, line.number,
                "a status of 0 without the report's data: " + quoted(line.text));
  }
  auto matched = detail::match_fields(line, specs);
  if (!matched) return std::unexpected(matched.error());
  return DataLine{leading->status, std::move(*matched)};
}

// The one line of a reply, which must end, with nothing but noise after it.
template <typename Read>
auto one_line_reply(std::string_view reply, Read read) -> decltype(read(std::declval<const Line&>())) {
  LineSplitter lines(reply);
  const auto line = detail::first_line(reply, lines);
  if (!line) return std::unexpected(line.error());
  auto result = read(*line);
  if (!result) return result;
  if (auto error = detail::check_end(*line, lines)) return std::unexpected(*error);
  return result;
}

std::expected<double, ProtocolError> number_field(std::string_view text, std::size_t index, const Line& line) {
  if (const auto value = fields::number(text)) return *value;
  return fail(Kind::garbled, line.number, fmt::format("field {} is out of range: {}", index + 1, quoted(text)));
}

std::string_view trim_trailing_blanks(std::string_view text) {
  while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
  return text;
}

// ---- Layouts ------------------------------------------------------------------------------

using fields::kCctField;
using fields::kChromaticityField;
using fields::kLabelField;
using fields::kNumberField;
using fields::kSignedNumberField;
using fields::kStatusField;
using fields::kUnitsField;
using fields::kValueField;
using fields::kWholeField;

constexpr std::array kReport1{kStatusField, kUnitsField, kValueField, kChromaticityField, kChromaticityField};
constexpr std::array kReport2{kStatusField, kUnitsField, kValueField, kValueField, kValueField};
constexpr std::array kReport4{kStatusField, kUnitsField, kValueField, kCctField, kSignedNumberField};
constexpr std::array kReport6{kStatusField,       kUnitsField,        kValueField,       kChromaticityField,
                              kChromaticityField, kChromaticityField, kChromaticityField};

// Y,x,y and Y,u',v' share a layout.
struct ReportLayout {
  int report;
  std::span<const FieldSpec> fields;
};
constexpr ReportLayout kColorimetricLayouts[] = {
    {1, kReport1}, {2, kReport2}, {3, kReport1}, {4, kReport4}, {6, kReport6}};

std::span<const FieldSpec> colorimetric_layout(int report) {
  for (const auto& layout : kColorimetricLayouts) {
    if (layout.report == report) return layout.fields;
  }
  return {};
}

// D120 without and with the pixel fields.
constexpr std::array kConfiguration{kStatusField, kWholeField, kNumberField, kWholeField, kWholeField, kWholeField};
constexpr std::array kConfigurationWithPixels{kStatusField, kWholeField, kNumberField, kWholeField, kWholeField,
                                              kWholeField,  kWholeField, kWholeField,  kWholeField};

constexpr std::array kApertureLine{kStatusField, kWholeField, kLabelField, kNumberField};

// "16500 msec": D13's exposure.
Match match_milliseconds(std::string_view text) {
  constexpr std::string_view kUnit = " msec";
  const auto blank = text.find(' ');
  const Match digits = fields::match_whole(text.substr(0, blank));
  if (blank == std::string_view::npos) return digits == Match::mismatch ? Match::mismatch : Match::prefix;
  if (digits != Match::full) return Match::mismatch;
  const std::string_view unit = text.substr(blank);
  if (unit == kUnit) return Match::full;
  return kUnit.starts_with(unit) ? Match::prefix : Match::mismatch;
}
constexpr FieldSpec kMillisecondsField{match_milliseconds, "exposure such as \"16500 msec\""};
constexpr std::array kExposureReport{kStatusField, kLabelField, kMillisecondsField};

// ---- Flicker ------------------------------------------------------------------------------

// "60.00 Hertz (Period = 16.67 milliseconds)": the number, then (when present) the unit and a
// parenthesis that is not read. A bare number is accepted too.
std::expected<double, ProtocolError> frequency_of(std::string_view text, const Line& line) {
  constexpr std::string_view kUnit = " Hertz";
  const auto blank = text.find(' ');
  const std::string_view digits = text.substr(0, blank);
  const Match match = fields::match_number(digits);
  if (match == Match::prefix && blank == std::string_view::npos && !line.terminated) {
    return fail(Kind::truncated, line.number, "the frequency is cut short: " + quoted(text));
  }
  if (match != Match::full) return fail(Kind::garbled, line.number, "expected a frequency, got " + quoted(text));
  const std::string_view after = blank == std::string_view::npos ? std::string_view() : text.substr(blank);
  const bool unit_ok = after.empty() || after.starts_with(kUnit) || (!line.terminated && kUnit.starts_with(after));
  if (!unit_ok || !detail::is_printable(after)) {
    return fail(Kind::garbled, line.number, "expected \"Hertz\" after the frequency, got " + quoted(after));
  }
  return number_field(digits, 1, line);
}

}  // namespace

std::expected<Status, ProtocolError> parse_status(std::string_view reply) {
  return one_line_reply(reply, [](const Line& line) -> std::expected<Status, ProtocolError> {
    const auto leading = fields::leading_status(line);
    if (!leading) return std::unexpected(leading.error());
    if (leading->rest) return fail(Kind::surplus, line.number, "more than a status: " + quoted(line.text));
    return leading->status;
  });
}

std::expected<TextReport, ProtocolError> parse_text_report(std::string_view reply) {
  return one_line_reply(reply, [](const Line& line) -> std::expected<TextReport, ProtocolError> {
    const auto leading = fields::leading_status(line);
    if (!leading) return std::unexpected(leading.error());
    if (leading->status.code != 0) return TextReport{leading->status, {}};
    const std::string_view text = trim_trailing_blanks(leading->rest.value_or(""));
    if (text.empty()) {
      const bool cut = !line.terminated;
      return fail(cut ? Kind::truncated : Kind::garbled, line.number, "the report is empty: " + quoted(line.text));
    }
    if (!detail::is_printable(text)) return fail(Kind::garbled, line.number, "a non-printable byte in " + quoted(text));
    return TextReport{leading->status, std::string(text)};
  });
}

std::expected<HardwareConfiguration, ProtocolError> parse_hardware_configuration(std::string_view reply) {
  return one_line_reply(reply, [](const Line& line) -> std::expected<HardwareConfiguration, ProtocolError> {
    const bool with_pixels = detail::split_fields(line.text).size() > kConfiguration.size();
    const auto data =
        read_data_line(line, with_pixels ? std::span<const FieldSpec>(kConfigurationWithPixels) : kConfiguration);
    if (!data) return std::unexpected(data.error());
    HardwareConfiguration result{data->status, {}, 0, {}, {}, {}};
    if (data->fields.empty()) return result;
    const auto& f = data->fields;
    const auto bandwidth = number_field(f[2], 2, line);
    if (!bandwidth) return std::unexpected(bandwidth.error());
    result.grid = Grid{fields::whole(f[3]), fields::whole(f[4]), fields::whole(f[5]), fields::whole(f[1])};
    result.bandwidth_nm = *bandwidth;
    if (with_pixels) {
      result.pixels = fields::whole(f[6]);
      result.first_pixel = fields::whole(f[7]);
      result.last_pixel = fields::whole(f[8]);
    }
    if (!result.grid.consistent()) {
      return fail(Kind::garbled, line.number,
                  fmt::format("{} points do not fit {}-{} nm by {} nm", result.grid.points, result.grid.first_nm,
                              result.grid.last_nm, result.grid.step_nm));
    }
    return result;
  });
}

std::expected<FlickerReply, ProtocolError> parse_flicker(std::string_view reply) {
  return one_line_reply(reply, [](const Line& line) -> std::expected<FlickerReply, ProtocolError> {
    const auto leading = fields::leading_status(line);
    if (!leading) return std::unexpected(leading.error());
    if (leading->status.code != 0) return FlickerReply{leading->status, std::nullopt};
    if (!leading->rest) {
      return fail(line.terminated ? Kind::garbled : Kind::truncated, line.number,
                  "a status of 0 without a frequency: " + quoted(line.text));
    }
    const auto hz = frequency_of(*leading->rest, line);
    if (!hz) return std::unexpected(hz.error());
    return FlickerReply{leading->status, *hz};
  });
}

std::expected<ApertureList, ProtocolError> parse_apertures(std::string_view reply) {
  LineSplitter lines(reply);
  const auto first = detail::first_line(reply, lines);
  if (!first) return std::unexpected(first.error());
  ApertureList result;
  for (std::optional<Line> line = *first; line; line = lines.next_content()) {
    const auto data = read_data_line(*line, kApertureLine);
    if (!data) return std::unexpected(data.error());
    if (data->status.code != 0) {
      if (!result.apertures.empty()) {
        return fail(Kind::garbled, line->number, "a status other than 0 among the apertures: " + quoted(line->text));
      }
      result.status = data->status;
      if (auto error = detail::check_end(*line, lines)) return std::unexpected(*error);
      return result;
    }
    if (!line->terminated) return fail(Kind::truncated, line->number, "the aperture line has no line end");
    const auto bandwidth = number_field(data->fields[3], 3, *line);
    if (!bandwidth) return std::unexpected(bandwidth.error());
    result.status = data->status;
    result.apertures.push_back({fields::whole(data->fields[1]), std::string(data->fields[2]), *bandwidth});
  }
  return result;
}

std::expected<ExposureReport, ProtocolError> parse_exposure_report(std::string_view reply) {
  return one_line_reply(reply, [](const Line& line) -> std::expected<ExposureReport, ProtocolError> {
    const auto data = read_data_line(line, kExposureReport);
    if (!data) return std::unexpected(data.error());
    if (data->fields.empty()) return ExposureReport{data->status, {}, 0};
    return ExposureReport{data->status, std::string(data->fields[1]), fields::whole(data->fields[2])};
  });
}

std::expected<ColorimetricReport, ProtocolError> parse_colorimetric(int report, std::string_view reply) {
  const auto layout = colorimetric_layout(report);
  if (layout.empty()) return fail(Kind::garbled, 0, fmt::format("report {} is not a colorimetric report", report));
  return one_line_reply(reply, [&](const Line& line) -> std::expected<ColorimetricReport, ProtocolError> {
    const auto data = read_data_line(line, layout);
    if (!data) return std::unexpected(data.error());
    ColorimetricReport result{report, data->status, 0, {}};
    if (data->fields.empty()) return result;
    result.units = fields::whole(data->fields[1]);
    for (std::size_t i = 2; i < data->fields.size(); ++i) {
      const auto value = number_field(data->fields[i], i, line);
      if (!value) return std::unexpected(value.error());
      result.values.push_back(*value);
    }
    return result;
  });
}

}  // namespace skinspec::drivers::pr6xx
