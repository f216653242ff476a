#pragma once
// PNG encoding with libpng: the image's linear sRGB clipped to [0, 1], gamma-encoded with the
// sRGB curve and tagged as sRGB. Bytes out; writing them anywhere is the caller's business.

#include <expected>
#include <string>
#include <vector>

#include "skinspec/render/image.hpp"

namespace skinspec::render {

// What the picture shows, which decides how it is compressed. A rendering or a photograph has
// smooth gradients, which PNG's per-row filters turn into small differences; a false-colour map
// takes its few hundred colours from a colour map, and there the filters only add noise: left
// unfiltered and deflated at zlib's fastest level, a 512 x 512 map encodes 3 to 6 times faster
// and comes out smaller (docs/benchmarks.md, "Skin maps").
enum class PngContent { continuous_tone, false_colour };

// bits: 8 or 16 per channel.
std::expected<std::vector<unsigned char>, std::string> encode_png(const Image& image, int bits,
                                                                  PngContent content = PngContent::continuous_tone);

}  // namespace skinspec::render
