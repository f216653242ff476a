#pragma once
// Cubes inside containers of arrays (HDF5, MATLAB v7.3 files among them, and netCDF), read
// through GDAL's multidimensional API (docs/maps.md, "Cubes").

#include <gdal_priv.h>

#include <cstddef>
#include <expected>
#include <memory>
#include <string>
#include <vector>

#include "skinspec/maps/cube.hpp"

namespace skinspec::maps::detail {

// A cube inside a container of arrays (HDF5, such as MATLAB v7.3 files, or netCDF): its one
// three-dimensional array, read as an image whose bands run along the dimension as long as a
// one-dimensional array named for wavelengths ("wavelength", "wavelengths", "wl", "lambda"),
// which gives their centres: in nm, or as its "units" attribute says. MATLAB writes its arrays
// in column order, so there the image's first other dimension is its samples; elsewhere (C
// order) its lines.
struct ArrayCube {
  std::unique_ptr<GDALDataset> container;
  std::shared_ptr<GDALMDArray> array;
  std::size_t band_dim = 0, sample_dim = 0, line_dim = 0;
  std::vector<double> wavelength_nm;
};

// Errors name the field at fault: no or several three-dimensional arrays ("bands"), no array of
// wavelengths or none as long as a dimension ("wavelength"), an unknown unit.
std::expected<ArrayCube, CubeError> open_array_cube(const std::string& path);

}  // namespace skinspec::maps::detail
