// What a PR-6xx/7xx sends, byte for byte, for the simulator and for tests. The formatters assume
// what the meter itself would print: finite values, codes within their widths, a spectral
// report with one wavelength per value.

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <system_error>

#include <fmt/format.h>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers::pr6xx {

namespace {

constexpr std::string_view kLineEnd = "\r\n";
// Colorimetric values and the header's integrals: two exponent digits in every example.
constexpr int kReportExponentDigits = 2;
// The spectral header's peak field: "0.000e+000" in every manual.
constexpr int kPeakExponentDigits = 3;

// A status as the meter prints it: zero-padded when not negative; an error short ("-8") or
// padded to four digits ("-0008").
std::string status_text(int code, int digits, const ReplyStyle& style) {
  if (code >= 0) return fmt::format("{:0{}}", code, digits);
  return style.padded_errors ? fmt::format("-{:04}", -code) : fmt::format("{}", code);
}

std::string data_status(int code, const ReplyStyle& style) {
  return status_text(code, style.data_status_digits, style);
}

std::string chromaticity(double value) { return fmt::format("{:.4f}", value); }

std::string colorimetric_value(int report, std::size_t index, double value, char exponent) {
  if (index == 0 || report == 2) return format_value(value, kReportExponentDigits, exponent);
  if (report == 4) {
    // CCT right-aligned in five characters (clients read it as an integer); the deviation.
    return index == 1 ? fmt::format("{:5}", std::lround(value)) : chromaticity(value);
  }
  return chromaticity(value);
}

}  // namespace

ReplyStyle reply_style(const WireStyle& wire) {
  return ReplyStyle{wire.data_status_digits,   wire.setup_status_digits, wire.padded_errors,
                    wire.data_exponent_digits, wire.exponent_letter,     wire.banner};
}

std::string format_value(double value, int exponent_digits, char exponent) {
  const std::string text = fmt::format("{:.3e}", value);  // "-9.910e-07", "1.000e+100"
  const auto e = text.find('e');
  if (e == std::string::npos || e + 2 >= text.size()) return text;  // "nan", "inf": no meter prints them
  std::string mantissa = text.substr(0, e);
  int power = 0;
  const char* first = text.data() + e + (text[e + 1] == '+' ? 2 : 1);
  if (std::from_chars(first, text.data() + text.size(), power).ec != std::errc{}) return text;
  const int limit = exponent_digits == 2 ? 99 : 999;
  if (power < -limit) {
    mantissa = "0.000";
    power = 0;
  } else if (power > limit) {
    mantissa = value < 0 ? "-9.999" : "9.999";
    power = limit;
  }
  return fmt::format("{}{}{}{:0{}}", mantissa, exponent, power < 0 ? '-' : '+', std::abs(power), exponent_digits);
}

std::string format_banner(const ReplyStyle& style) {
  return std::string(kBanner) + (style.banner == BannerEnd::crlf ? std::string(kLineEnd) : std::string());
}

std::string format_setup_status(int code, const ReplyStyle& style) {
  return status_text(code, style.setup_status_digits, style) + std::string(kLineEnd);
}

std::string format_error(int code, const ReplyStyle& style) { return data_status(code, style) + std::string(kLineEnd); }

std::string format_text_report(std::string_view text, const ReplyStyle& style) {
  return fmt::format("{},{}{}", data_status(0, style), text, kLineEnd);
}

std::string format_hardware_configuration(const HardwareConfiguration& configuration, const ReplyStyle& style) {
  if (configuration.status.code != 0) return format_error(configuration.status.code, style);
  const Grid& grid = configuration.grid;
  std::string out = fmt::format("{},{},{:.2f},{},{},{}", data_status(0, style), grid.points, configuration.bandwidth_nm,
                                grid.first_nm, grid.last_nm, grid.step_nm);
  if (configuration.pixels) {
    out += fmt::format(",{},{},{}", *configuration.pixels, configuration.first_pixel.value_or(0),
                       configuration.last_pixel.value_or(0));
  }
  return out + std::string(kLineEnd);
}

std::string format_flicker_reply(const FlickerReply& reply, const ReplyStyle& style) {
  if (reply.status.code != 0 || !reply.hz) return format_setup_status(reply.status.code, style);
  return fmt::format("{},{:.2f} Hertz (Period = {:.2f} milliseconds){}",
                     status_text(0, style.setup_status_digits, style), *reply.hz, 1000 / *reply.hz, kLineEnd);
}

std::string format_apertures_reply(const std::vector<Aperture>& apertures, const ReplyStyle& style) {
  std::string out;
  for (const Aperture& aperture : apertures) {
    out += fmt::format("{},{},{},{:.2f}{}", data_status(0, style), aperture.code, aperture.name, aperture.bandwidth_nm,
                       kLineEnd);
  }
  return out;
}

std::string format_exposure_report(const ExposureReport& report, const ReplyStyle& style) {
  if (report.status.code != 0) return format_error(report.status.code, style);
  return fmt::format("{},{},{} msec{}", data_status(0, style), report.gain, report.exposure_ms, kLineEnd);
}

std::string format_colorimetric_reply(const ColorimetricReport& report, const ReplyStyle& style) {
  if (report.status.code != 0) return format_error(report.status.code, style);
  std::string out = fmt::format("{},{}", data_status(0, style), report.units);
  for (std::size_t i = 0; i < report.values.size(); ++i) {
    out += ',';
    out += colorimetric_value(report.report, i, report.values[i], style.exponent);
  }
  return out + std::string(kLineEnd);
}

std::string format_spectral_reply(const SpectralReport& report, const ReplyStyle& style) {
  if (report.status.code != 0) return format_error(report.status.code, style);
  std::string out =
      fmt::format("{},{},{},{},{}{}", data_status(0, style), report.units,
                  format_value(report.peak_nm, kPeakExponentDigits, style.exponent),
                  format_value(report.integrated, kReportExponentDigits, style.exponent),
                  format_value(report.integrated_photon, kReportExponentDigits, style.exponent), kLineEnd);
  out.reserve(out.size() + report.values.size() * 17);
  for (std::size_t i = 0; i < report.values.size() && i < report.wavelength_nm.size(); ++i) {
    out += fmt::format("{},{}{}", report.wavelength_nm[i],
                       format_value(report.values[i], style.data_exponent_digits, style.exponent), kLineEnd);
  }
  return out;
}

}  // namespace skinspec::drivers::pr6xx
