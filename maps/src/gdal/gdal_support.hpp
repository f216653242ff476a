#pragma once
// What the maps' readers and writer share of GDAL, and of reading wavelengths.

#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/maps/cube.hpp"

namespace skinspec::maps::detail {

// GDAL once per process: every driver registered (a cube is opened with kCubeDrivers alone);
// no side files (a .aux.xml beside a cube that was only read); a small block cache; GDAL's
// errors kept for our messages, not printed.
void start_gdal();
// The formats a cube is read in, as GDAL's lists of driver names. GDAL reads some two hundred,
// and some of them name other files or addresses: a VRT file's bands can be any raw file the
// process may read, a WMS file's a web server. Offered one of those as a cube, the service
// would read its own database or TLS key, or fetch an address inside the lab's network.
inline constexpr const char* kCubeDrivers[] = {"ENVI", "GTiff", "HDF5", "netCDF", nullptr};
inline constexpr const char* kArrayDrivers[] = {"HDF5", "netCDF", nullptr};
inline constexpr const char* kCubeFormats = "ENVI, TIFF, HDF5 or netCDF";

// One of GDAL's configuration options set for this thread while it lives (unset: nullptr).
class ThreadOption {
 public:
  ThreadOption(const char* name, const char* value);
  ~ThreadOption();
  ThreadOption(const ThreadOption&) = delete;
  ThreadOption& operator=(const ThreadOption&) = delete;

 private:
  const char* name_;
};

// GDAL's raw formats (ENVI) read into and written from the caller's buffer straight, a run of
// one band's samples at a time, rather than through GDAL's block cache, which allocates and
// fills a block for each line of each band (and, for a map's answers, kept them all to write
// when the file closed: 60 ms of closing a 512 x 512 map). For a cube stored band by band or
// line by line: a 512 x 512 x 101 BIL cube read in 0.08 s rather than 0.16 s. Not for one
// stored pixel by pixel, where each band's read would read every line whole again (0.31 s for
// 0.10 s). Nor for several lines of one band into a plain buffer: GDAL 3.6 then reads them as
// one run of bytes, as if they were contiguous in the file, which in a BIL file they are not;
// a line at a time is right.
// Where not `wanted`, GDAL chooses as it would.
inline ThreadOption direct_raw_io(bool wanted = true) { return {"GDAL_ONE_BIG_READ", wanted ? "YES" : nullptr}; }

// The files GDAL opens read without its cache of file blocks (VSI_CACHE, start_gdal). A map's
// answer cube is read back a band at a time, a line's 2 kB at a time from lines of 38 kB:
// through that cache each read loaded a 32 kB block, and a band of a 512 x 512 map took 80 ms
// rather than 2 ms.
inline ThreadOption uncached_files() { return {"VSI_CACHE", "FALSE"}; }

// GDAL's last error message, or a word that it gave none.
std::string last_gdal_error();
std::string lower(std::string_view text);
// Nanometres per unit of a "wavelength units" value; nullopt for one we do not know.
std::optional<double> nanometres_per(std::string_view units);
// The values if finite and increasing, else an error naming `file`'s wavelength field.
std::expected<std::vector<double>, CubeError> increasing(std::vector<double> values, const std::string& file);

}  // namespace skinspec::maps::detail
