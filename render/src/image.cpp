#include "skinspec/render/image.hpp"

#include <algorithm>

namespace skinspec::render {

Image::Image(int width, int height, Rgb fill)
    : width_(width),
      height_(height),
      pixels_(static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0)), fill) {}

void Image::paste(const Image& other, int x, int y) {
  for (int row = std::max(0, -y); row < other.height() && y + row < height_; ++row)
    for (int col = std::max(0, -x); col < other.width() && x + col < width_; ++col)
      at(x + col, y + row) = other.at(col, row);
}

Image contact_sheet(std::string_view title, const std::vector<LabelledImage>& cells, int columns) {
  constexpr int kMargin = 12, kTextScale = 2;
  constexpr int kLineHeight = kGlyphHeight * kTextScale;
  constexpr Rgb kPaper{0.9f, 0.9f, 0.9f}, kInk{0.0f, 0.0f, 0.0f};
  int cell_w = 0, cell_h = 0;
  for (const auto& c : cells) {
    cell_w = std::max({cell_w, c.image.width(), text_width(c.label, kTextScale)});
    cell_h = std::max(cell_h, c.image.height());
  }
  columns = std::max(1, std::min<int>(columns, static_cast<int>(cells.size())));
  const int rows = (static_cast<int>(cells.size()) + columns - 1) / columns;
  const int pitch_x = cell_w + kMargin, pitch_y = cell_h + kLineHeight + 2 * kMargin;
  const int top = kMargin + kLineHeight + kMargin;
  const int width = std::max(kMargin + columns * pitch_x, 2 * kMargin + text_width(title, kTextScale));
  Image sheet(width, top + rows * pitch_y, kPaper);
  draw_text(sheet, kMargin, kMargin, title, kTextScale, kInk);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const int x = kMargin + static_cast<int>(i) % columns * pitch_x;
    const int y = top + static_cast<int>(i) / columns * pitch_y;
    sheet.paste(cells[i].image, x, y);
    draw_text(sheet, x, y + cell_h + kMargin / 2, cells[i].label, kTextScale, kInk);
  }
  return sheet;
}

}  // namespace skinspec::render
