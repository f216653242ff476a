#include "fitter_loader.hpp"

#include "data_dir.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec {

std::expected<Fitter, std::string> load_fitter(const std::filesystem::path& dir_given) {
  const auto dir = dir_given.empty() ? find_data_dir() : dir_given;
  const DataReader read = directory_reader(dir);
  std::vector<SkinOptics> models;
  for (const ModelKind kind : kModelKinds) {
    auto optics = SkinOptics::load(read, kind);
    if (!optics) return std::unexpected((dir / optics.error().what()).string());
    models.push_back(std::move(*optics));
  }
  Table tables[2];
  const char* names[] = {"colour/cie1931_2deg_cmf.csv", "colour/cie_illuminants.csv"};
  for (int i = 0; i < 2; ++i) {
    auto bytes = read(names[i]);
    if (!bytes) return std::unexpected(bytes.error());
    auto table = parse_table(*bytes, (dir / names[i]).string(), {});
    if (!table) return std::unexpected(table.error().what());
    tables[i] = std::move(*table);
  }
  auto colorimetry = Colorimetry::from_tables(tables[0], tables[1]);
  if (!colorimetry) return std::unexpected(colorimetry.error().what());
  return Fitter(std::move(models), std::move(*colorimetry));
}

}  // namespace skinspec
