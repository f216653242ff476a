// The only file of render/ that talks to libpng.

#include "skinspec/render/png.hpp"

#include <cmath>
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

// Rows of gamma-encoded samples, 16-bit ones big-endian as PNG stores them.
std::vector<unsigned char> encoded_rows(const Image& image, int bits) {
  const int bytes_per_sample = bits / 8;
  const double top = bits == 8 ? 255.0 : 65535.0;
  std::vector<unsigned char> out;
  out.reserve(static_cast<std::size_t>(image.width()) * static_cast<std::size_t>(image.height()) * 3u *
              static_cast<std::size_t>(bytes_per_sample));
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const Rgb& p = image.at(x, y);
      for (const float linear : {p.r, p.g, p.b}) {
        const auto code = static_cast<unsigned>(std::lround(srgb_encode(static_cast<double>(linear)) * top));
        if (bits == 16) out.push_back(static_cast<unsigned char>(code >> 8));
        out.push_back(static_cast<unsigned char>(code & 0xff));
      }
    }
  return out;
}

// libpng reports failure by longjmp; nothing with a destructor is created between setjmp and
// the end of this function, so the jump skips no clean-up.
bool write_png(png_structp png, png_infop info, const Image& image, int bits, std::vector<unsigned char*>& rows,
               std::vector<unsigned char>* out) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_write_fn(png, out, append_bytes, no_flush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width()), static_cast<png_uint_32>(image.height()), bits,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  return true;
}

}  // namespace

std::expected<std::vector<unsigned char>, std::string> encode_png(const Image& image, int bits) {
  if (bits != 8 && bits != 16) return std::unexpected("PNG depth must be 8 or 16 bits, not " + std::to_string(bits));
  if (image.width() < 1 || image.height() < 1) return std::unexpected(std::string("cannot encode an empty image"));
  std::vector<unsigned char> samples = encoded_rows(image, bits);
  const std::size_t stride = samples.size() / static_cast<std::size_t>(image.height());
  std::vector<unsigned char*> rows;
  for (int y = 0; y < image.height(); ++y) rows.push_back(samples.data() + static_cast<std::size_t>(y) * stride);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  std::vector<unsigned char> out;
  const bool written = info && write_png(png, info, image, bits, rows, &out);
  png_destroy_write_struct(&png, &info);
  if (!written) return std::unexpected(std::string("libpng could not encode the image"));
  return out;
}

}  // namespace skinspec::render
