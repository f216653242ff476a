#pragma once
// The model the programs fit with: the optical tables and colorimetry from a data directory.

#include <expected>
#include <filesystem>
#include <string>

#include "skinspec/fit/fitter.hpp"

namespace skinspec {

// Loads data/ at `dir` (find_data_dir() when empty); an explanation naming the file otherwise.
std::expected<Fitter, std::string> load_fitter(const std::filesystem::path& dir = {});

}  // namespace skinspec
