#pragma once
// A spectral image ("cube": lines × samples × bands) read through GDAL: ENVI of every
// interleave, data type and byte order, multi-band float TIFF, HDF5. Its wavelengths, scale and
// ignore value come from the header (docs/maps.md, "Cubes"). Lines are read in blocks, so that
// memory stays bounded whatever the cube's size.

#include <cstddef>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::maps {

namespace gdal_io {
class CubeData;
}

// What is wrong with a cube: the file, the header field (empty when none is to blame) and why.
struct CubeError {
  std::string file;
  std::string field;
  std::string message;
  std::string what() const;  // "FILE: FIELD: MESSAGE"
};

struct CubeInfo {
  std::string file;
  // Every file the cube is read from (an ENVI cube's header and data file), as GDAL names them.
  std::vector<std::string> files;
  std::size_t lines = 0, samples = 0, bands = 0;
  std::vector<double> wavelength_nm;  // one per band, increasing
  // What a stored value is divided by to give reflectance as a fraction (the ENVI header's
  // "reflectance scale factor"; 1 when absent).
  double reflectance_scale = 1;
  std::optional<double> ignore_value;  // "data ignore value", or the band's no-data value
  // The largest value the data type stores (integer types): a pixel holding it is saturated.
  std::optional<double> type_maximum;
};

// A cube sent as one file (an upload to the service): a TIFF, HDF5 or netCDF file is the cube
// itself; a tar archive, plain or gzipped (`tar cf - cube.hdr cube.img`), of an ENVI header and
// its data file is unpacked into `dir` (by its members' names alone, never their directories),
// and the header is the cube. Errors name `name`: an archive without exactly one .hdr, a member
// that is not a plain file, more than kMaxArchiveMembers.
inline constexpr std::size_t kMaxArchiveMembers = 16;
std::expected<std::string, CubeError> cube_of_upload(const std::string& file, const std::string& dir,
                                                     const std::string& name);

class Cube {
 public:
  // Errors name the file and the header field at fault: a file GDAL cannot read as a raster,
  // sizes that disagree with the data file, a data type that is not a real number,
  // wavelengths missing, unparsable or not increasing.
  static std::expected<Cube, CubeError> open(const std::string& path);
  ~Cube();
  Cube(Cube&&) noexcept;
  Cube& operator=(Cube&&) noexcept;

  const CubeInfo& info() const { return info_; }
  // `count` lines from `first`, as stored values (not yet divided by the scale), pixel by
  // pixel: value (line, sample, band) at ((line - first) * samples + sample) * bands + band.
  // Errors: a data file shorter than its header says.
  std::expected<std::vector<float>, CubeError> read_lines(std::size_t first, std::size_t count) const;
  // The same into `values`, resized to hold them, whose memory is used again: a map reads block
  // after block into the same two, sparing a block's zero fill and fresh pages each time.
  std::expected<void, CubeError> read_lines(std::size_t first, std::size_t count, std::vector<float>& values) const;

 private:
  Cube(std::unique_ptr<gdal_io::CubeData> data, CubeInfo info);
  std::unique_ptr<gdal_io::CubeData> data_;  // read through GDAL, in its module (gdal_io.hpp)
  CubeInfo info_;
};

}  // namespace skinspec::maps
