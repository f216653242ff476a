#pragma once
// Finding and reading skinspec's data directory: the one place where its tables (optics,
// colorimetry, model constants) meet the file system.

#include <expected>
#include <filesystem>
#include <string>

#include "skinspec/spectral/table.hpp"

namespace skinspec {

// The data directory: $SKINSPEC_DATA_DIR when set; else ../share/skinspec/data beside the
// running program (an installed copy); else the source tree's data/ this build came from.
std::filesystem::path find_data_dir();

// Whole-file read; the error names the path and the reason.
std::expected<std::string, std::string> read_file(const std::filesystem::path& path);

// A DataReader over a directory.
DataReader directory_reader(std::filesystem::path dir);

}  // namespace skinspec
