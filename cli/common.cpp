#include "common.hpp"

#include <filesystem>
#include <iostream>
#include <iterator>

#include "data_dir.hpp"
#include "fitter_loader.hpp"

namespace skinspec::cli {

std::string input_name(const std::string& path) { return path == "-" ? "<stdin>" : path; }

std::string read_input(const std::string& path) {
  if (path == "-") return {std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>()};
  // A directory opens and reads as zero bytes, which would be reported as an empty file.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw Failure{kBadInput, path + ": is a directory, not a file"};
  auto bytes = read_file(path);
  if (!bytes) throw Failure{kBadInput, bytes.error()};
  return *bytes;
}

std::vector<NamedSpectrum> read_spectra(const std::string& path) {
  auto spectra = parse_spectra_csv(read_input(path), input_name(path));
  if (!spectra) throw Failure{kBadInput, spectra.error().what()};
  return std::move(*spectra);
}

const Fitter& fitter() {
  static const Fitter instance = [] {
    auto loaded = load_fitter();
    if (!loaded) throw Failure{kBadInput, loaded.error()};
    return std::move(*loaded);
  }();
  return instance;
}

CLI::Option* add_site_option(CLI::App& app, std::string& site) {
  return app.add_option("--site", site, "body site: forearm, back_of_hand, cheek, forehead, palm")
      ->capture_default_str();
}

}  // namespace skinspec::cli
