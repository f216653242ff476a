#pragma once
// The models the programs fit with (every ModelKind): the optical tables, each model's
// constants and colorimetry from a data directory.

#include <expected>
#include <filesystem>
#include <string>

#include "skinspec/fit/fitter.hpp"

namespace skinspec {

// Loads data/ at `dir` (find_data_dir() when empty); an explanation naming the file otherwise.
std::expected<Fitter, std::string> load_fitter(const std::filesystem::path& dir = {});

}  // namespace skinspec
