#pragma once
// PNG encoding with libpng: the image's linear sRGB clipped to [0, 1], gamma-encoded with the
// sRGB curve and tagged as sRGB. Bytes out; writing them anywhere is the caller's business.

#include <expected>
#include <string>
#include <vector>

#include "skinspec/render/image.hpp"

namespace skinspec::render {

// bits: 8 or 16 per channel.
std::expected<std::vector<unsigned char>, std::string> encode_png(const Image& image, int bits);

}  // namespace skinspec::render
