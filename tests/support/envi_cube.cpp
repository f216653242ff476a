#include "support/envi_cube.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

namespace skinspec::testing {

namespace {

template <typename T>
void append(std::string& bytes, T value, bool big_endian) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if (big_endian == (std::endian::native == std::endian::little))
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
  bytes.append(raw, sizeof(T));
}

}  // namespace

std::filesystem::path write_envi(const std::filesystem::path& stem, const CubeValues& cube, const EnviLayout& layout,
                                 const std::string& extra_header, bool write_wavelengths) {
  std::string bytes(layout.header_offset, '\0');
  const auto put = [&](std::size_t l, std::size_t s, std::size_t b) {
    const double v = cube.values[(l * cube.samples + s) * cube.bands + b] * layout.scale;
    if (layout.uint16) append(bytes, static_cast<std::uint16_t>(std::lround(v)), layout.big_endian);
    else append(bytes, static_cast<float>(v), layout.big_endian);
  };
  switch (layout.interleave) {
    case Interleave::bsq:
      for (std::size_t b = 0; b < cube.bands; ++b)
        for (std::size_t l = 0; l < cube.lines; ++l)
          for (std::size_t s = 0; s < cube.samples; ++s) put(l, s, b);
      break;
    case Interleave::bil:
      for (std::size_t l = 0; l < cube.lines; ++l)
        for (std::size_t b = 0; b < cube.bands; ++b)
          for (std::size_t s = 0; s < cube.samples; ++s) put(l, s, b);
      break;
    case Interleave::bip:
      for (std::size_t l = 0; l < cube.lines; ++l)
        for (std::size_t s = 0; s < cube.samples; ++s)
          for (std::size_t b = 0; b < cube.bands; ++b) put(l, s, b);
      break;
  }
  const char* interleave = layout.interleave == Interleave::bsq   ? "bsq"
                           : layout.interleave == Interleave::bil ? "bil"
                                                                  : "bip";
  std::ostringstream header;
  header << "ENVI\nsamples = " << cube.samples << "\nlines = " << cube.lines << "\nbands = " << cube.bands
         << "\nheader offset = " << layout.header_offset
         << "\nfile type = ENVI Standard\ndata type = " << (layout.uint16 ? 12 : 4) << "\ninterleave = " << interleave
         << "\nbyte order = " << (layout.big_endian ? 1 : 0) << "\n";
  if (layout.scale != 1) header << "reflectance scale factor = " << layout.scale << "\n";
  if (write_wavelengths) {
    header << "wavelength units = Nanometers\nwavelength = {";
    for (std::size_t b = 0; b < cube.bands; ++b) header << (b ? ", " : "") << cube.wavelength_nm[b];
    header << "}\n";
  }
  header << extra_header;
  std::filesystem::path hdr = stem, img = stem;
  hdr += ".hdr";
  img += ".img";
  std::ofstream(hdr, std::ios::binary) << header.str();
  std::ofstream(img, std::ios::binary) << bytes;
  return hdr;
}

}  // namespace skinspec::testing
