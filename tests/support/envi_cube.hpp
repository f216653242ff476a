#pragma once
// Writes a spectral cube as an ENVI header and raw file in any layout the format has (BSQ, BIL,
// BIP; float32 or uint16 with a reflectance scale factor; either byte order), written byte by
// byte here rather than through GDAL, so that the reader is checked against files it did not
// make.

#include <filesystem>
#include <string>
#include <vector>

namespace skinspec::testing {

enum class Interleave { bsq, bil, bip };

struct EnviLayout {
  Interleave interleave = Interleave::bil;
  bool uint16 = false;      // else float32
  double scale = 1;         // "reflectance scale factor": stored = reflectance * scale
  bool big_endian = false;  // "byte order = 1"
  std::size_t header_offset = 0;
};

// Reflectance at (line, sample, band) is values[(line * samples + sample) * bands + band].
struct CubeValues {
  std::size_t lines = 0, samples = 0, bands = 0;
  std::vector<double> wavelength_nm;
  std::vector<double> values;
  double& at(std::size_t line, std::size_t sample, std::size_t band) {
    return values[(line * samples + sample) * bands + band];
  }
};

// Skin-like reflectance spectra, 400-760 nm by 5 nm (rising towards the red, a haemoglobin dip
// near 560 nm), varied a little from pixel to pixel, each value a multiple of 1/4096.
CubeValues skin_cube(std::size_t lines, std::size_t samples);

// Writes STEM.hdr and STEM.img; returns the header's path. `extra_header` is appended to the
// header as is; `write_wavelengths` false leaves the wavelength field out.
std::filesystem::path write_envi(const std::filesystem::path& stem, const CubeValues& cube, const EnviLayout& layout,
                                 const std::string& extra_header = {}, bool write_wavelengths = true);

// A cube every reader must refuse, and the header field its refusal names.
struct BadCube {
  std::string name, field;
};
// Writes DIR/NAME.hdr and DIR/NAME.img for each bad cube: an unknown data type (field "data
// type"), sizes that disagree with the data file ("lines"), decreasing wavelengths, none, bands
// of 600-960 nm that miss 420-680 nm ("wavelength"), and a truncated data file ("lines").
std::vector<BadCube> write_bad_cubes(const std::filesystem::path& dir);

// A GDAL VRT whose bands are the float32 values of `raw`, a file stored pixel by pixel (each
// pixel's bands together), one band a wavelength: a "cube" that names another file.
std::string raw_file_vrt(const std::filesystem::path& raw, std::size_t lines, std::size_t samples,
                         const std::vector<double>& wavelength_nm);

}  // namespace skinspec::testing
