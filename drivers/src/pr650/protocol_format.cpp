// What a PR-650 sends, byte for byte, for the simulator and for tests. The formatters assume
// valid input (non-negative finite values below 1E+100, chromaticities below 1, codes that
// fit their widths): checking it is the caller's job, as the meter never prints anything else.

#include <cmath>

#include <fmt/format.h>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650 {

namespace {

constexpr std::string_view kLineEnd = "\r\n";

// ".3355": four decimals and no leading zero, as the meter prints chromaticities.
std::string format_chromaticity(double value) {
  std::string text = fmt::format("{:.4f}", value);
  if (text.starts_with("0.")) text.erase(0, 1);
  return text;
}

// A CCT deviation may be negative: "-.0031" or ".0031".
std::string format_signed_chromaticity(double value) {
  return value < 0 ? "-" + format_chromaticity(-value) : format_chromaticity(value);
}

// How each report prints the values after "qq,U,".
std::string format_report_value(int report, std::size_t index, double value, char exponent) {
  const bool chromaticity = (report == 1 || report == 3 || report == 6) && index > 0;
  if (chromaticity) return format_chromaticity(value);
  if (report == 4 && index == 2) return format_signed_chromaticity(value);
  return format_value(value, exponent);
}

}  // namespace

std::string format_value(double value, char exponent) {
  std::string text = fmt::format("{:.3e}", value);  // "5.882e-05"
  // The meter has two exponent digits; anything smaller than 1E-99 reads as zero.
  if (text.size() > 9 && text[6] == '-') text = fmt::format("{:.3e}", 0.0);
  text[5] = exponent;
  return text;
}

std::string format_status_reply(int status) { return fmt::format("{:03}{}", status, kLineEnd); }

std::string format_setup_reply(int code) { return fmt::format("{:02}{}", code, kLineEnd); }

std::string format_flicker_reply(const FlickerReply& reply) {
  return fmt::format("{:02},{:.2f}{}", reply.quality, reply.frequency_hz, kLineEnd);
}

std::string format_colorimetric_reply(const ColorimetricReport& report, const ReplyStyle& style) {
  std::string out = fmt::format("{:02},{}", report.quality, report.units);
  for (std::size_t i = 0; i < report.values.size(); ++i) {
    out += ',';
    out += format_report_value(report.report, i, report.values[i], style.exponent);
  }
  out += kLineEnd;
  return out;
}

std::string format_spectral_reply(const SpectralReport& report, const ReplyStyle& style) {
  const std::string_view separator = style.header == HeaderVariant::h1_bare_cr ? "\r" : kLineEnd;
  std::string out = fmt::format("{:02},{}{}{}{}", report.quality, report.units, separator,
                                format_value(report.integrated, style.exponent), kLineEnd);
  out.reserve(out.size() + report.values.size() * 17);
  for (std::size_t i = 0; i < report.values.size(); ++i) {
    // Without wavelengths of its own the report is on the native grid.
    const double nm =
        i < report.wavelength_nm.size() ? report.wavelength_nm[i] : kFirstNm + kStepNm * static_cast<double>(i);
    out += fmt::format("{:04}.,{}{}", std::lround(nm), format_value(report.values[i], style.exponent), kLineEnd);
  }
  return out;
}

std::string format_serial_number_reply(std::string_view serial) { return fmt::format("{}{}", serial, kLineEnd); }

std::string format_spectral_configuration_reply(const SpectralConfiguration& configuration) {
  return fmt::format("{:04},{:05.1f},{:04.0f}.,{:04.0f}.,{:03.0f}.{}", configuration.points, configuration.bandwidth_nm,
                     configuration.first_nm, configuration.last_nm, configuration.step_nm, kLineEnd);
}

}  // namespace skinspec::drivers::pr650
