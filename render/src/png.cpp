// The only file of render/ that talks to libpng.

#include "skinspec/render/png.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <csetjmp>
#include <png.h>

#include "skinspec/spectral/colour.hpp"

namespace skinspec::render {

namespace {

void append_bytes(png_structp png, png_bytep data, png_size_t size) {
  auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + size);
}

void no_flush(png_structp) {}

unsigned srgb_code(float linear, double top) {
  return static_cast<unsigned>(std::lround(srgb_encode(static_cast<double>(linear)) * top));
}

// The 8-bit code of a linear value, exactly as srgb_code gives it, without a pow: the code
// steps up at 255 values, found once by bisection over the floats of [0, 1] (the bit patterns
// of non-negative floats order as their values do), and a value's code is the number of steps
// at or below it. This needs srgb_code never to fall from one float to the next: neighbouring
// floats are far further apart than pow's error, and the curve's two pieces meet at code 10.3,
// away from a rounding point. A picture's pow per sample was a fifth of drawing a map's
// pictures (docs/benchmarks.md, "Skin maps"). The floats of (0, 1] fall into buckets of 2^15
// neighbours by their bit patterns; each bucket starts from the code of its least float, and a
// bucket spans less than a step, so a value's code is its bucket's or the next: a search
// through the steps for every sample was a third of encoding a map's picture.
class EightBitCodes {
 public:
  EightBitCodes() {
    for (unsigned code = 1; code <= 255; ++code) {
      std::uint32_t below = std::bit_cast<std::uint32_t>(0.0f), at = std::bit_cast<std::uint32_t>(1.0f);
      while (at - below > 1) {
        const std::uint32_t middle = below + (at - below) / 2;
        (srgb_code(std::bit_cast<float>(middle), 255) >= code ? at : below) = middle;
      }
      steps_[code - 1] = std::bit_cast<float>(at);
    }
    for (std::size_t bucket = 0; bucket < first_codes_.size(); ++bucket) {
      const float least = std::bit_cast<float>(static_cast<std::uint32_t>(bucket << kBucketBits));
      first_codes_[bucket] = static_cast<std::uint8_t>(searched_code(least));
    }
  }
  unsigned code(float linear) const {
    if (!(linear > 0 && linear <= 1)) return srgb_code(linear, 255);  // clipped, or NaN
    unsigned code = first_codes_[std::bit_cast<std::uint32_t>(linear) >> kBucketBits];
    while (code < 255 && linear >= steps_[code]) ++code;
    return code;
  }

 private:
  static constexpr unsigned kBucketBits = 15;
  unsigned searched_code(float linear) const {
    return static_cast<unsigned>(std::upper_bound(steps_.begin(), steps_.end(), linear) - steps_.begin());
  }

  std::array<float, 255> steps_{};  // steps_[c - 1]: the least float whose code is at least c
  // The code of each bucket's least float, for the buckets of (0, 1].
  std::array<std::uint8_t, (std::bit_cast<std::uint32_t>(1.0f) >> kBucketBits) + 1> first_codes_{};
};

// Rows of gamma-encoded samples, 16-bit ones big-endian as PNG stores them.
std::vector<unsigned char> encoded_rows(const Image& image, int bits) {
  static const EightBitCodes eight_bit;
  const int bytes_per_sample = bits / 8;
  std::vector<unsigned char> out;
  out.reserve(static_cast<std::size_t>(image.width()) * static_cast<std::size_t>(image.height()) * 3u *
              static_cast<std::size_t>(bytes_per_sample));
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const Rgb& p = image.at(x, y);
      for (const float linear : {p.r, p.g, p.b}) {
        if (bits == 8) {
          out.push_back(static_cast<unsigned char>(eight_bit.code(linear)));
          continue;
        }
        const unsigned code = srgb_code(linear, 65535);
        out.push_back(static_cast<unsigned char>(code >> 8));
        out.push_back(static_cast<unsigned char>(code & 0xff));
      }
    }
  return out;
}

// libpng reports failure by longjmp; nothing with a destructor is created between setjmp and
// the end of this function, so the jump skips no clean-up.
bool write_png(png_structp png, png_infop info, const Image& image, int bits, PngContent content,
               std::vector<unsigned char*>& rows, std::vector<unsigned char>* out) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_write_fn(png, out, append_bytes, no_flush);
  if (content == PngContent::false_colour) {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    png_set_compression_level(png, 1);
  }
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width()), static_cast<png_uint_32>(image.height()), bits,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  return true;
}

}  // namespace

std::expected<std::vector<unsigned char>, std::string> encode_png(const Image& image, int bits, PngContent content) {
  if (bits != 8 && bits != 16) return std::unexpected("PNG depth must be 8 or 16 bits, not " + std::to_string(bits));
  if (image.width() < 1 || image.height() < 1) return std::unexpected(std::string("cannot encode an empty image"));
  std::vector<unsigned char> samples = encoded_rows(image, bits);
  const std::size_t stride = samples.size() / static_cast<std::size_t>(image.height());
  std::vector<unsigned char*> rows;
  for (int y = 0; y < image.height(); ++y) rows.push_back(samples.data() + static_cast<std::size_t>(y) * stride);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  std::vector<unsigned char> out;
  const bool written = info && write_png(png, info, image, bits, content, rows, &out);
  png_destroy_write_struct(&png, &info);
  if (!written) return std::unexpected(std::string("libpng could not encode the image"));
  return out;
}

}  // namespace skinspec::render
