#include "skinspec/maps/cube.hpp"

#include <fmt/format.h>

#include "gdal_io.hpp"

namespace skinspec::maps {

std::string CubeError::what() const {
  return field.empty() ? fmt::format("{}: {}", file, message) : fmt::format("{}: {}: {}", file, field, message);
}

std::expected<std::string, CubeError> cube_of_upload(const std::string& file, const std::string& dir,
                                                     const std::string& name) {
  return gdal_io::io().cube_of_upload(file, dir, name);
}

Cube::Cube(std::unique_ptr<gdal_io::CubeData> data, CubeInfo info) : data_(std::move(data)), info_(std::move(info)) {}
Cube::~Cube() = default;
Cube::Cube(Cube&&) noexcept = default;
Cube& Cube::operator=(Cube&&) noexcept = default;

std::expected<Cube, CubeError> Cube::open(const std::string& path) {
  auto opened = gdal_io::io().open_cube(path);
  if (!opened) return std::unexpected(opened.error());
  return Cube(std::move(opened->data), std::move(opened->info));
}

std::expected<std::vector<float>, CubeError> Cube::read_lines(std::size_t first, std::size_t count) const {
  std::vector<float> values;
  if (auto read = data_->read_lines(info_, first, count, values); !read) return std::unexpected(read.error());
  return values;
}

std::expected<void, CubeError> Cube::read_lines(std::size_t first, std::size_t count,
                                                std::vector<float>& values) const {
  return data_->read_lines(info_, first, count, values);
}

}  // namespace skinspec::maps
