// The GDAL module's entry point (gdal_io.hpp): the one symbol it exports.

#include "gdal/answer_file.hpp"
#include "gdal/cube_reader.hpp"
#include "gdal_io.hpp"

namespace skinspec::maps {
namespace {

class GdalIo final : public gdal_io::Io {
 public:
  std::expected<gdal_io::OpenedCube, CubeError> open_cube(const std::string& path) const override {
    return open_gdal_cube(path);
  }
  std::expected<std::string, CubeError> cube_of_upload(const std::string& file, const std::string& dir,
                                                       const std::string& name) const override {
    return unpack_cube_upload(file, dir, name);
  }
  std::expected<std::unique_ptr<gdal_io::AnswerFile>, std::string> create_answer_file(const std::filesystem::path& file,
                                                                                      const CubeInfo& cube,
                                                                                      const std::vector<MapBand>& bands,
                                                                                      bool envi) const override {
    return create_gdal_answer_file(file, cube, bands, envi);
  }
};

}  // namespace
}  // namespace skinspec::maps

extern "C" __attribute__((visibility("default"))) const skinspec::maps::gdal_io::Io* skinspec_gdal_io() {
  static const skinspec::maps::GdalIo io;
  return &io;
}
