#include "skinspec/maps/map_writer.hpp"

#include "gdal_support.hpp"
#include "skinspec/maps/map_picture.hpp"
#include "skinspec/render/png.hpp"

#include <gdal_priv.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <system_error>
#include <unistd.h>

namespace skinspec::maps {

namespace fs = std::filesystem;

struct MapWriter::State {
  fs::path dir, partial, name, cube_file;
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

// A map killed outright (SIGKILL, a power cut) leaves its hidden directory behind, under no
// final name. Those of the same cube whose process is gone are removed when it is mapped
// again; one whose process still runs is another map's, and is left alone.
void remove_abandoned(const fs::path& dir, const std::string& name) {
  const std::string prefix = fmt::format(".{}.partial-", name);
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string file = entry.path().filename().string();
    if (!file.starts_with(prefix)) continue;
    pid_t pid = 0;
    const char* digits = file.data() + prefix.size();
    const auto [end, parsed] = std::from_chars(digits, file.data() + file.size(), pid);
    if (parsed != std::errc() || end != file.data() + file.size() || pid <= 0) continue;
    if (::kill(pid, 0) == -1 && errno == ESRCH) fs::remove_all(entry.path(), error);
  }
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
                                                        const CubeInfo& cube, std::vector<MapBand> bands,
                                                        MapFormat format) {
  auto state = std::make_unique<State>();
  state->dir = dir;
  state->name = name;
  state->partial = dir / fmt::format(".{}.partial-{}", name, ::getpid());
  state->samples = cube.samples;
  state->bands = bands.size();
  std::error_code error;
  fs::create_directories(state->partial, error);
  if (error) return std::unexpected(fmt::format("{}: cannot create: {}", dir.string(), error.message()));
  remove_abandoned(dir, name);
  detail::start_gdal();
  const bool envi = format == MapFormat::envi;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(envi ? "ENVI" : "GTiff");
  if (!driver) return std::unexpected(fmt::format("GDAL has no {} driver", envi ? "ENVI" : "GTiff"));
  // ENVI: the header GDAL writes is the data file's name with ".hdr" for its extension.
  const char* envi_options[] = {"INTERLEAVE=BIL", nullptr};
  const char* tiff_options[] = {"INTERLEAVE=BAND", "TILED=YES", "BIGTIFF=IF_SAFER", nullptr};
  state->cube_file = state->partial / (name + (envi ? ".map.img" : ".map.tif"));
  state->cube.reset(driver->Create(state->cube_file.c_str(), static_cast<int>(cube.samples),
                                   static_cast<int>(cube.lines), static_cast<int>(bands.size()), GDT_Float32,
                                   const_cast<char**>(envi ? envi_options : tiff_options)));
  if (!state->cube)
    return std::unexpected(fmt::format("{}: cannot create: {}", state->cube_file.string(), CPLGetLastErrorMsg()));
  std::string units = "{";
  for (std::size_t b = 0; b < bands.size(); ++b) {
    GDALRasterBand* band = state->cube->GetRasterBand(static_cast<int>(b + 1));
    band->SetDescription(bands[b].name.c_str());
    band->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());  // not determined, or not skin
    units += (b ? ", " : " ") + header_item(bands[b].unit);
  }
  if (envi) state->cube->SetMetadataItem("band_units", (units + " }").c_str(), "ENVI");
  // A TIFF's bands carry their names (above) and units as GDAL band metadata.
  for (std::size_t b = 0; b < bands.size() && !envi; ++b)
    state->cube->GetRasterBand(static_cast<int>(b + 1))->SetMetadataItem("unit", bands[b].unit.c_str());
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

std::expected<std::vector<ParameterSummary>, std::string> MapWriter::close(ModelKind model, bool pictures) {
  CPLErrorReset();
  state_->cube->FlushCache(true);
  state_->cube.reset();  // closing writes the header
  if (CPLGetLastErrorType() >= CE_Failure)
    return std::unexpected(fmt::format("cannot write the map: {}", CPLGetLastErrorMsg()));
  std::unique_ptr<GDALDataset> cube(GDALDataset::Open(state_->cube_file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!cube) return std::unexpected(fmt::format("cannot read the map back: {}", CPLGetLastErrorMsg()));
  const auto lines = static_cast<std::size_t>(cube->GetRasterYSize());
  const auto read_band = [&](int index) -> std::expected<std::vector<float>, std::string> {
    std::vector<float> band(lines * state_->samples);
    if (cube->GetRasterBand(index)->RasterIO(GF_Read, 0, 0, static_cast<int>(state_->samples), static_cast<int>(lines),
                                             band.data(), static_cast<int>(state_->samples), static_cast<int>(lines),
                                             GDT_Float32, 0, 0, nullptr) != CE_None)
      return std::unexpected(fmt::format("cannot read the map back: {}", CPLGetLastErrorMsg()));
    return band;
  };
  const auto mask = read_band(static_cast<int>(state_->bands));
  if (!mask) return std::unexpected(mask.error());
  const auto bands = map_bands(model);
  std::vector<ParameterSummary> summaries;
  for (std::size_t p = 0; p < model_spec(model).params.size(); ++p) {
    const auto values = read_band(static_cast<int>(2 * p + 1));
    if (!values) return std::unexpected(values.error());
    std::vector<float> determined;
    for (const float v : *values)
      if (!std::isnan(v)) determined.push_back(v);
    std::ranges::sort(determined);
    const auto percentile = [&](int q) {
      return determined.empty()
                 ? std::numeric_limits<double>::quiet_NaN()
                 : static_cast<double>(determined[(determined.size() - 1) * static_cast<std::size_t>(q) / 100]);
    };
    ParameterSummary summary{bands[2 * p], determined.size(), {}, {percentile(2), percentile(98)}};
    for (std::size_t q = 0; q < kSummaryPercentiles.size(); ++q)
      summary.percentiles[q] = percentile(kSummaryPercentiles[q]);
    summaries.push_back(summary);
    if (!pictures) continue;
    const auto picture = render::encode_png(parameter_picture(*values, *mask, lines, state_->samples, bands[2 * p],
                                                              summary.picture_range[0], summary.picture_range[1]),
                                            8);
    if (!picture) return std::unexpected(picture.error());
    const fs::path png = state_->partial / fmt::format("{}.{}.png", state_->name.string(), bands[2 * p].name);
    std::ofstream out(png, std::ios::binary);
    out.write(reinterpret_cast<const char*>(picture->data()), static_cast<std::streamsize>(picture->size()));
    if (!out.flush()) return std::unexpected(fmt::format("{}: cannot write", png.string()));
  }
  return summaries;
}

std::expected<std::vector<fs::path>, std::string> MapWriter::finish(const std::string& summary_json) {
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
