#include "common.hpp"

#include <filesystem>
#include <iostream>
#include <iterator>

#include "data_dir.hpp"

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

namespace {

Fitter load_fitter() {
  const auto dir = find_data_dir();
  const DataReader read = directory_reader(dir);
  auto optics = SkinOptics::load(read);
  if (!optics) throw Failure{kBadInput, (dir / optics.error().what()).string()};
  Table tables[2];
  const char* names[] = {"colour/cie1931_2deg_cmf.csv", "colour/cie_illuminants.csv"};
  for (int i = 0; i < 2; ++i) {
    auto bytes = read(names[i]);
    if (!bytes) throw Failure{kBadInput, bytes.error()};
    auto table = parse_table(*bytes, (dir / names[i]).string(), {});
    if (!table) throw Failure{kBadInput, table.error().what()};
    tables[i] = std::move(*table);
  }
  auto colorimetry = Colorimetry::from_tables(tables[0], tables[1]);
  if (!colorimetry) throw Failure{kBadInput, colorimetry.error().what()};
  return Fitter(std::move(*optics), std::move(*colorimetry));
}

}  // namespace

const Fitter& fitter() {
  static const Fitter instance = load_fitter();
  return instance;
}

CLI::Option* add_site_option(CLI::App& app, std::string& site) {
  return app.add_option("--site", site, "body site: forearm, back_of_hand, cheek, forehead, palm")
      ->capture_default_str();
}

}  // namespace skinspec::cli
