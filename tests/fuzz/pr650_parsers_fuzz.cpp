// libFuzzer target: arbitrary bytes into every PR-650 reply parser, reply_complete and
// strip_echo. Besides not crashing, whatever a parser accepts must be something the meter
// could have sent: a spectrum on the 380-780 nm grid with finite non-negative values, codes
// within their widths, and bytes that print back to a reply that reads the same.
// Build and run with scripts/fuzz.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace pr650 = skinspec::drivers::pr650;

namespace {

// Stops the run so that libFuzzer keeps the input that broke an invariant.
void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "pr650 invariant broken: %s\n", invariant);
    std::abort();
  }
}

bool finite_non_negative(double value) { return std::isfinite(value) && value >= 0; }

// An error names a line that exists (or the one after the last) and says something.
void check_error(const pr650::ProtocolError& error, std::string_view bytes) {
  std::size_t line_ends = 0;
  for (const char c : bytes) line_ends += c == '\r' || c == '\n';
  require(!error.message.empty(), "an error has a message");
  require(error.line <= line_ends + 1, "an error names a line of the reply");
}

void check_spectral(std::string_view bytes) {
  const auto report = pr650::parse_spectral(bytes);
  if (!report) {
    check_error(report.error(), bytes);
    return;
  }
  require(report->wavelength_nm.size() == pr650::kSpectralPoints, "101 wavelengths");
  require(report->values.size() == pr650::kSpectralPoints, "101 values");
  for (std::size_t i = 0; i < report->values.size(); ++i) {
    require(report->wavelength_nm[i] == pr650::kFirstNm + pr650::kStepNm * static_cast<double>(i),
            "wavelengths on the native grid");
    require(i == 0 || report->wavelength_nm[i] > report->wavelength_nm[i - 1], "wavelengths increase");
    require(finite_non_negative(report->values[i]), "values finite and non-negative");
  }
  require(finite_non_negative(report->integrated), "integrated value finite and non-negative");
  require(report->quality >= 0 && report->quality <= 99, "two-digit quality code");
  require(report->units >= 0 && report->units <= 2, "units code 0-2");
  require(pr650::reply_complete(pr650::ReplyShape::spectral, bytes), "a parsed report is complete");

  const auto again = pr650::parse_spectral(pr650::format_spectral_reply(*report));
  require(again.has_value(), "a printed report reads back");
  require(again->values == report->values && again->quality == report->quality && again->units == report->units &&
              again->integrated == report->integrated,
          "a printed report reads back the same");
}

void check_colorimetric(std::string_view bytes) {
  for (const int code : {1, 2, 3, 4, 5, 6}) {
    const auto report = pr650::parse_colorimetric(code, bytes);
    if (!report) {
      check_error(report.error(), bytes);
      continue;
    }
    require(code != 5, "report 5 is not colorimetric");
    require(report->report == code, "the report is the one asked for");
    require(report->values.size() == (code == 6 ? 5u : 3u), "the report's number of values");
    for (std::size_t i = 0; i < report->values.size(); ++i) {
      const bool may_be_negative = code == 4 && i == 2;  // deviation from the Planckian locus
      require(std::isfinite(report->values[i]), "colorimetric values finite");
      require(may_be_negative || report->values[i] >= 0, "colorimetric values non-negative");
    }
    require(report->quality >= 0 && report->quality <= 99, "two-digit quality code");
    require(report->units >= 0 && report->units <= 2, "units code 0-2");
    require(pr650::reply_complete(pr650::ReplyShape::line, bytes), "a parsed line is complete");
  }
}

void check_line_replies(std::string_view bytes) {
  if (const auto status = pr650::parse_status(bytes)) {
    require(*status >= 0 && *status <= 999, "status of at most three digits");
  } else {
    check_error(status.error(), bytes);
  }
  if (const auto setup = pr650::parse_setup_reply(bytes)) {
    require(*setup >= 0 && *setup <= 99, "setup reply of at most two digits");
    require(!pr650::setup_reply_message(*setup).empty(), "setup reply message");
  } else {
    check_error(setup.error(), bytes);
  }
  if (const auto flicker = pr650::parse_flicker(bytes)) {
    require(finite_non_negative(flicker->frequency_hz), "frequency finite and non-negative");
    require(flicker->quality >= 0 && flicker->quality <= 99, "two-digit quality code");
    require(!pr650::quality_message(flicker->quality).empty(), "quality message");
  } else {
    check_error(flicker.error(), bytes);
  }
  if (const auto serial = pr650::parse_serial_number(bytes)) {
    require(!serial->empty() && serial->size() <= 8, "serial number of 1-8 characters");
    require(serial->back() != ' ', "no trailing blank");
    for (const char c : *serial) require(c >= 0x20 && c <= 0x7e, "printable serial number");
  } else {
    check_error(serial.error(), bytes);
  }
  if (const auto configuration = pr650::parse_spectral_configuration(bytes)) {
    require(configuration->points >= 0, "point count non-negative");
    require(finite_non_negative(configuration->bandwidth_nm) && finite_non_negative(configuration->first_nm) &&
                finite_non_negative(configuration->last_nm) && finite_non_negative(configuration->step_nm),
            "configuration numbers finite and non-negative");
  } else {
    check_error(configuration.error(), bytes);
  }
}

void check_echo(std::string_view bytes) {
  for (const std::string_view command : {"d5\n", "b3\r", "s01,,,,,0,01,1\n", "d110\n", ""}) {
    const std::string_view stripped = pr650::strip_echo(bytes, command);
    require(stripped.size() <= bytes.size(), "strip_echo only removes");
    require(stripped.empty() ||
                (stripped.data() >= bytes.data() && stripped.data() + stripped.size() <= bytes.data() + bytes.size()),
            "strip_echo returns part of the reply");
    pr650::reply_complete(pr650::ReplyShape::line, stripped);
    pr650::reply_complete(pr650::ReplyShape::spectral, stripped);
  }
  const std::string_view stripped = pr650::strip_echo(bytes, "d5\n");
  if (stripped.size() != bytes.size()) check_spectral(stripped);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_spectral(bytes);
  check_colorimetric(bytes);
  check_line_replies(bytes);
  check_echo(bytes);
  return 0;
}
