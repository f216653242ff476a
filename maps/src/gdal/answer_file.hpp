#pragma once
// The GDAL module's writer of a map's answer cube (gdal_io.hpp).

#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "gdal_io.hpp"

namespace skinspec::maps {

std::expected<std::unique_ptr<gdal_io::AnswerFile>, std::string> create_gdal_answer_file(
    const std::filesystem::path& file, const CubeInfo& cube, const std::vector<MapBand>& bands, bool envi);

}  // namespace skinspec::maps
