// The PR-6xx/7xx spectral report (M5/D5): a header "qqqqq,U,peak,integrated,photon" and one
// line "nnn,d.ddde-ee" per wavelength of the grid D120 gave. The header is found by content
// (blank lines and prompts around it are noise); the data lines must run over exactly the
// expected grid with one exponent width throughout, so that a lost, repeated or damaged line is
// an error, never a plausible spectrum.

#include <algorithm>
#include <array>
#include <utility>

#include <fmt/format.h>

#include "pr6xx/fields.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx {

namespace {

using detail::fail;
using detail::Line;
using detail::LineSplitter;
using detail::Match;
using detail::quoted;
using Kind = ProtocolError::Kind;

constexpr std::array kHeader{fields::kStatusField, fields::kUnitsField, fields::kValueField, fields::kValueField,
                             fields::kValueField};

struct DataPoint {
  int wavelength_nm = 0;
  double value = 0;
  int exponent_digits = 0;
};

// "380,1.627e-06": a wavelength of 3 or 4 digits and a value.
Match match_data_line(std::string_view text) {
  const auto comma = text.find(',');
  const std::string_view wavelength = text.substr(0, comma);
  const bool digits = detail::all_digits(wavelength) && wavelength.size() <= 4;
  if (comma == std::string_view::npos) return digits ? Match::prefix : Match::mismatch;
  if (!digits || wavelength.size() < 3) return Match::mismatch;
  return fields::match_value(text.substr(comma + 1));
}

std::optional<int> wavelength_of(std::string_view text) {
  if (match_data_line(text) != Match::full) return std::nullopt;
  return detail::digits_value(text.substr(0, text.find(',')));
}

std::expected<DataPoint, ProtocolError> parse_data_line(const Line& line) {
  switch (match_data_line(line.text)) {
    case Match::full:
      break;
    case Match::prefix:
      if (!line.terminated) return fail(Kind::truncated, line.number, "data line cut short: " + quoted(line.text));
      [[fallthrough]];
    case Match::mismatch:
      return fail(Kind::garbled, line.number,
                  "expected a data line such as \"380,1.627e-06\", got " + quoted(line.text));
  }
  if (!line.terminated) return fail(Kind::truncated, line.number, "data line has no line end");
  const auto comma = line.text.find(',');
  const std::string_view value = line.text.substr(comma + 1);
  const auto number = fields::number(value);
  if (!number) return fail(Kind::garbled, line.number, "value out of range: " + quoted(value));
  return DataPoint{detail::digits_value(line.text.substr(0, comma)), *number, fields::exponent_digits(value)};
}

std::string describe(const Grid& grid) {
  return fmt::format("{}-{} nm by {} nm ({} points)", grid.first_nm, grid.last_nm, grid.step_nm, grid.points);
}

// The grid that the wavelengths run over, when they are regular.
std::optional<Grid> regular_grid(const std::vector<int>& wavelengths) {
  if (wavelengths.size() < 2) return std::nullopt;
  const int step = wavelengths[1] - wavelengths[0];
  if (step <= 0) return std::nullopt;
  for (std::size_t i = 1; i < wavelengths.size(); ++i) {
    if (wavelengths[i] - wavelengths[i - 1] != step) return std::nullopt;
  }
  return Grid{wavelengths.front(), wavelengths.back(), step, static_cast<int>(wavelengths.size())};
}

ProtocolError wrong_grid_error(std::size_t line, const Grid& found, const Grid& expected) {
  return detail::make_error(
      Kind::wrong_grid, line,
      fmt::format("the report runs over {} where the expected grid (D120) is {}", describe(found), describe(expected)));
}

// The wavelengths of the data lines read so far followed by those of the rest of the reply,
// up to the first line that is neither a data line nor noise.
std::vector<int> all_wavelengths(std::vector<int> so_far, LineSplitter rest) {
  while (auto line = rest.next_content()) {
    const auto nm = wavelength_of(line->text);
    if (!nm) break;
    so_far.push_back(*nm);
  }
  return so_far;
}

// A data line off the expected grid: a whole report on another grid, lost or repeated lines
// (the report still ends at the last wavelength), or a wavelength that is simply wrong.
ProtocolError off_grid_error(const Line& line, std::vector<int> read, const LineSplitter& rest, const Grid& expected) {
  const int found_nm = read.back();
  const int expected_nm = expected.first_nm + expected.step_nm * static_cast<int>(read.size() - 1);
  const auto wavelengths = all_wavelengths(std::move(read), rest);
  if (const auto grid = regular_grid(wavelengths)) return wrong_grid_error(line.number, *grid, expected);
  if (wavelengths.back() == expected.last_nm && wavelengths.size() != static_cast<std::size_t>(expected.points)) {
    return detail::make_error(Kind::wrong_count, line.number,
                              fmt::format("{} data lines where {} are expected ({} nm where {} nm should be)",
                                          wavelengths.size(), expected.points, found_nm, expected_nm));
  }
  return detail::make_error(Kind::wrong_wavelength, line.number,
                            fmt::format("{} nm where {} nm should be", found_nm, expected_nm));
}

std::optional<ProtocolError> read_header(const Line& line, SpectralReport& report) {
  const auto matched = detail::match_fields(line, kHeader);
  if (!matched) return matched.error();
  const auto& f = *matched;
  const auto peak = fields::number(f[2]), integrated = fields::number(f[3]), photon = fields::number(f[4]);
  if (!peak || !integrated || !photon) {
    return detail::make_error(Kind::garbled, line.number, "a header value out of range: " + quoted(line.text));
  }
  report.units = fields::whole(f[1]);
  report.peak_nm = *peak;
  report.integrated = *integrated;
  report.integrated_photon = *photon;
  return std::nullopt;
}

std::optional<ProtocolError> read_data(LineSplitter& lines, const Grid& expected, SpectralReport& report) {
  // No more than any model's report, whatever a damaged D120 said: the lines decide.
  constexpr int kLargestReport = 1024;
  report.wavelength_nm.reserve(static_cast<std::size_t>(std::min(expected.points, kLargestReport)));
  report.values.reserve(static_cast<std::size_t>(std::min(expected.points, kLargestReport)));
  for (int i = 0; i < expected.points; ++i) {
    const auto line = lines.next_content();
    if (!line) {
      return detail::make_error(Kind::truncated, lines.lines_read() + 1,
                                fmt::format("the reply ends after {} of {} data lines", i, expected.points));
    }
    const auto point = parse_data_line(*line);
    if (!point) return point.error();
    if (i == 0) report.exponent_digits = point->exponent_digits;
    if (point->exponent_digits != report.exponent_digits) {
      return detail::make_error(Kind::garbled, line->number,
                                fmt::format("an exponent of {} digits where the first data line has {}: {}",
                                            point->exponent_digits, report.exponent_digits, quoted(line->text)));
    }
    report.wavelength_nm.push_back(point->wavelength_nm);
    if (point->wavelength_nm != expected.first_nm + expected.step_nm * i) {
      return off_grid_error(*line, report.wavelength_nm, lines, expected);
    }
    report.values.push_back(point->value);
  }
  return std::nullopt;
}

// After the last wavelength: a report that goes on regularly is on another grid; other data
// lines make too many; anything but noise is surplus.
std::optional<ProtocolError> check_tail(LineSplitter& lines, const Grid& expected, const SpectralReport& report) {
  while (auto line = lines.next()) {
    if (detail::is_prompt_or_blank(line->text)) continue;
    if (const auto nm = wavelength_of(line->text)) {
      auto read = report.wavelength_nm;
      read.push_back(*nm);
      if (const auto grid = regular_grid(all_wavelengths(std::move(read), lines))) {
        return wrong_grid_error(line->number, *grid, expected);
      }
      return detail::make_error(Kind::wrong_count, line->number,
                                fmt::format("more than {} data lines", expected.points));
    }
    return detail::make_error(
        Kind::surplus, line->number,
        fmt::format("unexpected bytes after the {} nm line: {}", expected.last_nm, quoted(line->text)));
  }
  return std::nullopt;
}

}  // namespace

std::expected<SpectralReport, ProtocolError> parse_spectral(std::string_view reply, const Grid& expected) {
  if (!expected.consistent()) {
    return fail(Kind::garbled, 0, "the expected grid is not a grid: " + describe(expected));
  }
  LineSplitter lines(reply);
  const auto header = detail::first_line(reply, lines);
  if (!header) return std::unexpected(header.error());
  const auto leading = fields::leading_status(*header);
  if (!leading) return std::unexpected(leading.error());
  if (!header->terminated) return fail(Kind::truncated, header->number, "the header has no line end");
  SpectralReport report;
  report.status = leading->status;
  // A failed measurement: the code alone, or a header whose data lines are not read.
  if (report.status.code != 0) return report;
  if (auto error = read_header(*header, report)) return std::unexpected(*error);
  if (auto error = read_data(lines, expected, report)) return std::unexpected(*error);
  if (auto error = check_tail(lines, expected, report)) return std::unexpected(*error);
  return report;
}

}  // namespace skinspec::drivers::pr6xx
