#include "skinspec/maps/map_writer.hpp"

#include "gdal_setup.hpp"

#include <gdal_priv.h>

#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <system_error>
#include <unistd.h>

namespace skinspec::maps {

namespace fs = std::filesystem;

struct MapWriter::State {
  fs::path dir, partial, name;
  std::size_t samples = 0, bands = 0;
  std::unique_ptr<GDALDataset> cube;
  bool finished = false;
};

namespace {

// An ENVI header list cannot hold commas inside its items.
std::string header_item(std::string text) {
  for (char& c : text)
    if (c == ',' || c == '{' || c == '}') c = ';';
  return text;
}

}  // namespace

MapWriter::MapWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}
MapWriter::MapWriter(MapWriter&&) noexcept = default;
MapWriter& MapWriter::operator=(MapWriter&&) noexcept = default;

MapWriter::~MapWriter() {
  if (!state_) return;
  state_->cube.reset();
  std::error_code ignored;
  fs::remove_all(state_->partial, ignored);
}

std::expected<MapWriter, std::string> MapWriter::create(const fs::path& dir, const std::string& name,
                                                        const CubeInfo& cube, std::vector<MapBand> bands) {
  auto state = std::make_unique<State>();
  state->dir = dir;
  state->name = name;
  state->partial = dir / fmt::format(".{}.partial-{}", name, ::getpid());
  state->samples = cube.samples;
  state->bands = bands.size();
  std::error_code error;
  fs::create_directories(state->partial, error);
  if (error) return std::unexpected(fmt::format("{}: cannot create: {}", dir.string(), error.message()));
  detail::start_gdal();
  GDALDriver* envi = GetGDALDriverManager()->GetDriverByName("ENVI");
  if (!envi) return std::unexpected("GDAL has no ENVI driver");
  const char* options[] = {"INTERLEAVE=BIL", nullptr};
  // The header GDAL writes is the data file's name with ".hdr" for its extension: NAME.map.hdr.
  const fs::path path = state->partial / (name + ".map.img");
  state->cube.reset(envi->Create(path.c_str(), static_cast<int>(cube.samples), static_cast<int>(cube.lines),
                                 static_cast<int>(bands.size()), GDT_Float32, const_cast<char**>(options)));
  if (!state->cube) return std::unexpected(fmt::format("{}: cannot create: {}", path.string(), CPLGetLastErrorMsg()));
  std::string units = "{";
  for (std::size_t b = 0; b < bands.size(); ++b) {
    GDALRasterBand* band = state->cube->GetRasterBand(static_cast<int>(b + 1));
    band->SetDescription(bands[b].name.c_str());
    band->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());  // not determined, or not skin
    units += (b ? ", " : " ") + header_item(bands[b].unit);
  }
  state->cube->SetMetadataItem("band_units", (units + " }").c_str(), "ENVI");
  state->cube->SetDescription(fmt::format("skinspec map of {}", cube.file).c_str());
  return MapWriter(std::move(state));
}

std::expected<void, std::string> MapWriter::write_lines(std::size_t first, std::size_t count,
                                                        std::span<const float> answers) {
  const auto bands = static_cast<GSpacing>(state_->bands);
  const CPLErr result = state_->cube->RasterIO(
      GF_Write, 0, static_cast<int>(first), static_cast<int>(state_->samples), static_cast<int>(count),
      const_cast<float*>(answers.data()), static_cast<int>(state_->samples), static_cast<int>(count), GDT_Float32,
      static_cast<int>(state_->bands), nullptr, bands * static_cast<GSpacing>(sizeof(float)),
      bands * static_cast<GSpacing>(state_->samples * sizeof(float)), static_cast<GSpacing>(sizeof(float)), nullptr);
  if (result != CE_None) return std::unexpected(fmt::format("cannot write the map: {}", CPLGetLastErrorMsg()));
  return {};
}

std::expected<std::vector<fs::path>, std::string> MapWriter::finish(const std::string& summary_json) {
  CPLErrorReset();
  state_->cube->FlushCache(true);
  state_->cube.reset();  // closing writes the header
  if (CPLGetLastErrorType() >= CE_Failure)
    return std::unexpected(fmt::format("cannot write the map: {}", CPLGetLastErrorMsg()));
  {
    std::ofstream summary(state_->partial / (state_->name.string() + ".summary.json"));
    summary << summary_json << '\n';
    if (!summary.flush()) return std::unexpected("cannot write the summary");
  }
  std::vector<fs::path> written;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(state_->partial)) {
    const fs::path target = state_->dir / entry.path().filename();
    fs::rename(entry.path(), target, error);
    if (error) return std::unexpected(fmt::format("{}: cannot move into place: {}", target.string(), error.message()));
    written.push_back(target);
  }
  fs::remove(state_->partial, error);
  return written;
}

}  // namespace skinspec::maps
