#pragma once
// What the maps do with GDAL, behind an interface that a module loaded on first use provides
// (libskinspec-gdal.so, built from gdal/). GDAL brings a hundred shared libraries, most of them
// bound at load: linked into skinspec and skinspecd they cost every start a tenth of a second,
// `skinspec --version` and `--help` too. Loaded here, only a program that reads or writes a cube
// pays it, once.

#include <cstddef>
#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "skinspec/maps/cube.hpp"
#include "skinspec/maps/map_band.hpp"

namespace skinspec::maps::gdal_io {

// An open cube's values (Cube::read_lines).
class CubeData {
 public:
  virtual ~CubeData() = default;
  virtual std::expected<void, CubeError> read_lines(const CubeInfo& info, std::size_t first, std::size_t count,
                                                    std::vector<float>& values) const = 0;
};

struct OpenedCube {
  std::unique_ptr<CubeData> data;
  CubeInfo info;
};

// A map's answer cube being written (MapWriter): float32, a band per MapBand.
class AnswerFile {
 public:
  virtual ~AnswerFile() = default;
  virtual std::expected<void, std::string> write_lines(std::size_t first, std::size_t count,
                                                       std::span<const float> answers) = 0;
  // Closes the file (writing the header), then opens it again to read it back.
  virtual std::expected<void, std::string> close_and_reopen() = 0;
  // Band `index` (from 1) of the reopened file, whole.
  virtual std::expected<std::vector<float>, std::string> read_band(int index) const = 0;
  virtual std::size_t lines() const = 0;
};

class Io {
 public:
  virtual ~Io() = default;
  virtual std::expected<OpenedCube, CubeError> open_cube(const std::string& path) const = 0;
  virtual std::expected<std::string, CubeError> cube_of_upload(const std::string& file, const std::string& dir,
                                                               const std::string& name) const = 0;
  // ENVI (band-interleaved by line) or, with `envi` false, a tiled float TIFF.
  virtual std::expected<std::unique_ptr<AnswerFile>, std::string> create_answer_file(const std::filesystem::path& file,
                                                                                     const CubeInfo& cube,
                                                                                     const std::vector<MapBand>& bands,
                                                                                     bool envi) const = 0;
};

// The module's, loaded on the first call. A module that cannot be loaded (skinspec installed
// without it) throws std::runtime_error naming the places looked in: no input is at fault.
const Io& io();

}  // namespace skinspec::maps::gdal_io

// The module's one entry point.
extern "C" const skinspec::maps::gdal_io::Io* skinspec_gdal_io();
