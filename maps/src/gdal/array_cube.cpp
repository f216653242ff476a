#include "gdal/array_cube.hpp"

#include <fmt/format.h>

#include "gdal/gdal_support.hpp"

namespace skinspec::maps::detail {

namespace {

bool names_wavelengths(const std::string& name) {
  const std::string n = lower(name);
  return n == "wavelength" || n == "wavelengths" || n == "wl" || n == "lambda";
}

std::expected<std::vector<double>, CubeError> array_values(GDALMDArray& array, const std::string& path) {
  std::vector<double> values(static_cast<std::size_t>(array.GetDimensions()[0]->GetSize()));
  const GUInt64 start = 0;
  const std::size_t count = values.size();
  if (!array.Read(&start, &count, nullptr, nullptr, GDALExtendedDataType::Create(GDT_Float64), values.data()))
    return std::unexpected(CubeError{path, "wavelength", fmt::format("cannot be read: {}", last_gdal_error())});
  if (const auto units = array.GetAttribute("units"); units && units->ReadAsString()) {
    const auto scale = nanometres_per(units->ReadAsString());
    if (!scale)
      return std::unexpected(
          CubeError{path, "wavelength units", fmt::format("unknown unit '{}'", units->ReadAsString())});
    for (double& w : values) w *= *scale;
  }
  return values;
}

}  // namespace

std::expected<ArrayCube, CubeError> open_array_cube(const std::string& path) {
  std::unique_ptr<GDALDataset> container(
      GDALDataset::Open(path.c_str(), GDAL_OF_MULTIDIM_RASTER | GDAL_OF_READONLY, kArrayDrivers));
  const auto root = container ? container->GetRootGroup() : nullptr;
  if (!root) return std::unexpected(CubeError{path, "bands", "the file holds no image and no arrays GDAL can read"});
  std::shared_ptr<GDALMDArray> cube, wavelengths;
  std::string names;
  for (const std::string& name : root->GetMDArrayNames()) {
    auto array = root->OpenMDArray(name);
    if (!array) continue;
    names += (names.empty() ? "" : ", ") + name;
    if (array->GetDimensionCount() == 3) {
      if (cube)
        return std::unexpected(
            CubeError{path, "bands", fmt::format("more than one three-dimensional array: {}", names)});
      cube = array;
    } else if (array->GetDimensionCount() == 1 && names_wavelengths(name)) {
      wavelengths = array;
    }
  }
  if (!cube)
    return std::unexpected(CubeError{path, "bands", fmt::format("no three-dimensional array among: {}", names)});
  if (!wavelengths)
    return std::unexpected(CubeError{path, "wavelength", fmt::format("no array of wavelengths among: {}", names)});
  auto values = array_values(*wavelengths, path);
  if (!values) return std::unexpected(values.error());
  const auto& dims = cube->GetDimensions();
  std::vector<std::size_t> image;  // the two dimensions that are not the bands'
  std::size_t band = dims.size();
  for (std::size_t d = 0; d < dims.size(); ++d) {
    if (band == dims.size() && dims[d]->GetSize() == values->size()) band = d;
    else image.push_back(d);
  }
  if (band == dims.size() || image.size() != 2)
    return std::unexpected(CubeError{
        path, "wavelength", fmt::format("{} wavelengths, but no dimension of the cube is as long", values->size())});
  const bool column_order = cube->GetAttribute("MATLAB_class") != nullptr;
  const std::size_t x = column_order ? image[0] : image[1], y = column_order ? image[1] : image[0];
  return ArrayCube{std::move(container), std::move(cube), band, x, y, std::move(*values)};
}

}  // namespace skinspec::maps::detail
