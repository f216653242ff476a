#pragma once
// What both readers of a CSV import share (import.cpp reads a file whole, import_stream.cpp a
// file of one row per spectrum a piece at a time): fields, wavelength headers and the range of
// a reflectance.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "finite_number.hpp"
#include "skinspec/spectral/reflectance_scale.hpp"

namespace skinspec::records::detail {

// A reflectance lies from a little below 0 (spectrometer noise over black) to 1.5, above which a
// value is no fraction (reflectance_scale.hpp).
inline constexpr double kLowestReflectance = -0.05;

inline bool is_reflectance(double value) { return value >= kLowestReflectance && value <= kPercentAbove; }

// Why `value`, read as `scale` says, is refused.
inline std::string not_a_reflectance(double value, const ScaleDecision& scale) {
  const double divisor = scale.divisor();
  return fmt::format("{} is not a reflectance ({} to {}{}){}", value, kLowestReflectance * divisor,
                     kPercentAbove * divisor, scale.scale == ReflectanceScale::percent ? " percent" : "",
                     out_of_range_note(scale, value));
}

inline std::string_view trimmed(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t");
  return text.substr(first, last - first + 1);
}

inline std::optional<double> wavelength_of(std::string_view header) {
  std::string_view text = trimmed(header);
  if (text.ends_with("nm")) text = trimmed(text.substr(0, text.size() - 2));
  const auto value = finite_number(text);
  if (!value || *value <= 0 || *value > 100000) return std::nullopt;
  return value;
}

inline bool names_wavelengths(std::string header) {
  std::ranges::transform(header, header.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::erase(header, ' ');
  return header == "wavelength_nm" || header == "wavelength" || header == "nm" || header == "wavelength(nm)" ||
         header == "lambda";
}

// The wavelength columns that end a header of one row per spectrum.
struct WavelengthColumns {
  std::size_t first = 0;  // the first of them; those before are text (the first the sample id)
  std::vector<double> grid;
};
struct HeaderDefect {
  std::size_t column = 0;  // 1-based; 0 for the whole line
  std::string message;
};

inline std::expected<WavelengthColumns, HeaderDefect> wavelength_columns(std::span<const std::string_view> header) {
  WavelengthColumns out{header.size(), {}};
  while (out.first > 0 && wavelength_of(header[out.first - 1])) --out.first;
  if (header.size() - out.first < 2)
    return std::unexpected(
        HeaderDefect{0,
                     "the header names no wavelengths: its first field is not wavelength_nm (one column per spectrum) "
                     "and it does not end in wavelength columns such as 400nm (one row per spectrum)"});
  for (std::size_t c = out.first; c < header.size(); ++c) {
    out.grid.push_back(*wavelength_of(header[c]));
    if (out.grid.size() > 1 && !(out.grid.back() > out.grid[out.grid.size() - 2]))
      return std::unexpected(HeaderDefect{c + 1, "the wavelengths must increase from column to column"});
  }
  return out;
}

}  // namespace skinspec::records::detail
