#include "support/envi_cube.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <random>
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

CubeValues skin_cube(std::size_t lines, std::size_t samples) {
  CubeValues cube{lines, samples, 0, {}, {}};
  for (double nm = 400; nm <= 760; nm += 5) cube.wavelength_nm.push_back(nm);
  cube.bands = cube.wavelength_nm.size();
  cube.values.resize(lines * samples * cube.bands);
  std::mt19937 random(3900);
  std::uniform_real_distribution vary(-0.03, 0.03);
  for (std::size_t l = 0; l < lines; ++l)
    for (std::size_t s = 0; s < samples; ++s) {
      const double shift = vary(random);
      for (std::size_t b = 0; b < cube.bands; ++b) {
        const double nm = cube.wavelength_nm[b];
        const double rise = 0.18 + 0.42 / (1 + std::exp(-(nm - 590) / 18));
        const double dip = 0.06 * std::exp(-std::pow((nm - 560) / 25, 2));
        cube.at(l, s, b) = std::round((rise - dip + shift) * 4096) / 4096;
      }
    }
  return cube;
}

std::vector<BadCube> write_bad_cubes(const std::filesystem::path& dir) {
  struct Case {
    BadCube cube;
    std::string from, to;  // the header's text changed
  };
  const CubeValues cube = skin_cube(3, 3);
  std::vector<BadCube> written;
  for (const Case& c :
       std::vector<Case>{{{"type", "data type"}, "data type = 4", "data type = 99"},
                         {{"sizes", "lines"}, "samples = 3", "samples = 4"},
                         {{"decreasing", "wavelength"}, "wavelength = {400, 405", "wavelength = {405, 400"},
                         {{"nowavelength", "wavelength"}, "wavelength = {", "wavelengths = {"},
                         {{"narrow", "wavelength"}, "", ""},
                         {{"truncated", "lines"}, "", ""}}) {
    const auto header = write_envi(dir / c.cube.name, cube, {});
    std::ifstream in(header);
    std::string text{std::istreambuf_iterator<char>(in), {}};
    in.close();
    if (!c.from.empty()) text.replace(text.find(c.from), c.from.size(), c.to);
    if (c.cube.name == "narrow") {  // every band 200 nm further: 600-960 nm
      std::string list = "wavelength = {";
      for (std::size_t b = 0; b < cube.bands; ++b) list += (b ? ", " : "") + std::to_string(600 + 5 * b);
      text = text.substr(0, text.find("wavelength = {")) + list + "}\n";
    }
    std::ofstream(header) << text;
    const auto data = dir / (c.cube.name + ".img");
    if (c.cube.name == "truncated") std::filesystem::resize_file(data, std::filesystem::file_size(data) / 2);
    written.push_back(c.cube);
  }
  return written;
}

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

std::string raw_file_vrt(const std::filesystem::path& raw, std::size_t lines, std::size_t samples,
                         const std::vector<double>& wavelength_nm) {
  const std::size_t bands = wavelength_nm.size();
  std::ostringstream vrt;
  vrt << "<VRTDataset rasterXSize=\"" << samples << "\" rasterYSize=\"" << lines << "\">";
  for (std::size_t band = 0; band < bands; ++band)
    vrt << "<VRTRasterBand dataType=\"Float32\" band=\"" << band + 1 << "\" subClass=\"VRTRawRasterBand\">"
        << "<Metadata><MDI key=\"wavelength\">" << wavelength_nm[band] << "</MDI></Metadata>"
        << "<SourceFilename>" << raw.string() << "</SourceFilename><ImageOffset>" << 4 * band
        << "</ImageOffset><PixelOffset>" << 4 * bands << "</PixelOffset><LineOffset>" << 4 * bands * samples
        << "</LineOffset></VRTRasterBand>";
  vrt << "</VRTDataset>";
  return vrt.str();
}

}  // namespace skinspec::testing
