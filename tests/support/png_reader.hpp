#pragma once
// Test helper: decodes PNG bytes with libpng, independently of the encoder under test.

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::testing {

struct DecodedPng {
  int width = 0, height = 0;
  int bits = 0;                    // per channel, as stored in the file
  std::vector<unsigned char> rgb;  // 8-bit sRGB codes, row by row, 3 per pixel

  std::array<int, 3> pixel(int x, int y) const {
    const auto i = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// Nothing when libpng refuses the bytes.
std::optional<DecodedPng> decode_png(const std::string& bytes);

}  // namespace skinspec::testing
