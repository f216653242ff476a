#pragma once
// Images in linear sRGB (not yet clipped or gamma-encoded), text in a small built-in bitmap
// font, and contact sheets of labelled images.

#include <string>
#include <string_view>
#include <vector>

namespace skinspec::render {

struct Rgb {
  float r = 0, g = 0, b = 0;
};

class Image {
 public:
  Image(int width, int height, Rgb fill = {});
  int width() const { return width_; }
  int height() const { return height_; }
  Rgb& at(int x, int y) { return pixels_[index(x, y)]; }
  const Rgb& at(int x, int y) const { return pixels_[index(x, y)]; }
  // Copies `other` with its top-left corner at (x, y), cropping what falls outside.
  void paste(const Image& other, int x, int y);

 private:
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x);
  }
  int width_, height_;
  std::vector<Rgb> pixels_;
};

// The font's glyphs are 5 x 7 cells, one cell of space between characters: digits, capital
// letters (lower case is drawn as capitals), space and . , : - + / ( ) % _. Anything else is
// drawn as a hollow box so that a missing glyph is seen, not silently dropped.
inline constexpr int kGlyphWidth = 5, kGlyphHeight = 7;
int text_width(std::string_view text, int scale);
// Draws text with its top-left corner at (x, y), each font cell scale x scale pixels.
void draw_text(Image& image, int x, int y, std::string_view text, int scale, Rgb colour);

struct LabelledImage {
  std::string label;
  Image image;
};

// A title above a grid of images in rows of `columns`, each image labelled beneath. Images may
// differ in size; every cell is as large as the largest.
Image contact_sheet(std::string_view title, const std::vector<LabelledImage>& cells, int columns);

}  // namespace skinspec::render
