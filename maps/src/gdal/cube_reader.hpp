#pragma once
// The GDAL module's readers (gdal_io.hpp): a cube opened, and an uploaded archive unpacked.

#include <expected>
#include <string>

#include "gdal_io.hpp"

namespace skinspec::maps {

// Cube::open's work: its errors as cube.hpp says.
std::expected<gdal_io::OpenedCube, CubeError> open_gdal_cube(const std::string& path);
// cube_of_upload's work (cube.hpp).
std::expected<std::string, CubeError> unpack_cube_upload(const std::string& file, const std::string& dir,
                                                         const std::string& name);

}  // namespace skinspec::maps
