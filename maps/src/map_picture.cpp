#include "skinspec/maps/map_picture.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fmt/format.h>
#include <string>

#include "skinspec/maps/colour_map.hpp"

namespace skinspec::maps {

namespace {

using render::Rgb;

constexpr int kMargin = 8, kBarWidth = 24, kBarHeight = 256, kGap = 12, kTextScale = 2, kSmallText = 1;
constexpr Rgb kBackground{1, 1, 1}, kInk{0, 0, 0};

Rgb rgb(const std::array<double, 3>& linear) {
  return {static_cast<float>(linear[0]), static_cast<float>(linear[1]), static_cast<float>(linear[2])};
}

// The built-in font has capitals, digits and a few signs (render/image.hpp); anything else in a
// unit becomes a space rather than a hollow box.
std::string printable(std::string_view text) {
  std::string out;
  for (const char c : text) {
    const bool drawn = std::isalnum(static_cast<unsigned char>(c)) ||
                       std::string_view(" .,:-+/()%_").find(c) != std::string_view::npos;
    const char kept = drawn ? c : ' ';
    if (kept != ' ' || (!out.empty() && out.back() != ' ')) out += kept;
  }
  return out;
}

std::string number(double v) { return fmt::format("{:.3g}", v); }

void fill(render::Image& image, int x, int y, int width, int height, Rgb colour) {
  for (int j = y; j < y + height; ++j)
    for (int i = x; i < x + width; ++i) image.at(i, j) = colour;
}

}  // namespace

render::Image parameter_picture(std::span<const float> values, std::span<const float> mask, std::size_t lines,
                                std::size_t samples, const MapBand& band, double low, double high) {
  const int enlarge = std::max<int>(1, static_cast<int>(256 / std::max<std::size_t>({lines, samples, 1})));
  const int map_width = static_cast<int>(samples) * enlarge, map_height = static_cast<int>(lines) * enlarge;
  const std::string title = printable(band.name), unit = printable(band.unit);
  const std::vector<std::string> ticks = {number(high), number((low + high) / 2), number(low)};
  int labels = 0;
  for (const auto& tick : ticks) labels = std::max(labels, render::text_width(tick, kTextScale));
  const int panel =
      std::max({kBarWidth + kGap + labels, render::text_width(title, kTextScale), render::text_width(unit, kSmallText),
                render::text_width("NOT SKIN", kTextScale) + kBarWidth + kGap});
  const int title_height = (render::kGlyphHeight + 2) * kTextScale + (render::kGlyphHeight + 2) * kSmallText + kGap;
  const int swatches = 2 * (kBarWidth + kGap);
  const int width = kMargin + map_width + 2 * kGap + panel + kMargin;
  const int height = kMargin + std::max(map_height, title_height + kBarHeight + kGap + swatches) + kMargin;
  render::Image image(width, height, kBackground);

  const Rgb not_determined = rgb(lab_to_linear_srgb(kNotDeterminedLab)), masked = rgb(lab_to_linear_srgb(kMaskedLab));
  const double span = high > low ? high - low : 1;
  for (std::size_t l = 0; l < lines; ++l)
    for (std::size_t s = 0; s < samples; ++s) {
      const std::size_t at = l * samples + s;
      const float v = values[at];
      const Rgb colour = mask[at] != 0   ? masked
                         : std::isnan(v) ? not_determined
                                         : rgb(map_linear_srgb((static_cast<double>(v) - low) / span));
      fill(image, kMargin + static_cast<int>(s) * enlarge, kMargin + static_cast<int>(l) * enlarge, enlarge, enlarge,
           colour);
    }

  const int x = kMargin + map_width + 2 * kGap;
  render::draw_text(image, x, kMargin, title, kTextScale, kInk);
  render::draw_text(image, x, kMargin + (render::kGlyphHeight + 2) * kTextScale, unit, kSmallText, kInk);
  const int bar_top = kMargin + title_height;
  for (int j = 0; j < kBarHeight; ++j)
    fill(image, x, bar_top + j, kBarWidth, 1, rgb(map_linear_srgb(1.0 - static_cast<double>(j) / (kBarHeight - 1))));
  const int label_x = x + kBarWidth + kGap, glyph = render::kGlyphHeight * kTextScale;
  render::draw_text(image, label_x, bar_top, ticks[0], kTextScale, kInk);
  render::draw_text(image, label_x, bar_top + (kBarHeight - glyph) / 2, ticks[1], kTextScale, kInk);
  render::draw_text(image, label_x, bar_top + kBarHeight - glyph, ticks[2], kTextScale, kInk);
  const int swatch_top = bar_top + kBarHeight + kGap;
  fill(image, x, swatch_top, kBarWidth, kBarWidth, not_determined);
  render::draw_text(image, label_x, swatch_top + (kBarWidth - glyph) / 2, "N.D.", kTextScale, kInk);
  fill(image, x, swatch_top + kBarWidth + kGap, kBarWidth, kBarWidth, masked);
  render::draw_text(image, label_x, swatch_top + kBarWidth + kGap + (kBarWidth - glyph) / 2, "NOT SKIN", kTextScale,
                    kInk);
  return image;
}

}  // namespace skinspec::maps
