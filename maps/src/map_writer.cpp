#include "skinspec/maps/map_writer.hpp"

#include "gdal_io.hpp"
#include "skinspec/maps/map_picture.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/spectral/parallel.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <mutex>
#include <system_error>
#include <unistd.h>

namespace skinspec::maps {

namespace fs = std::filesystem;

struct MapWriter::State {
  fs::path dir, partial, name;
  std::size_t samples = 0, bands = 0;
  std::unique_ptr<gdal_io::AnswerFile> cube;  // written through GDAL (gdal_io.hpp)
  bool finished = false;
};

namespace {

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

// How many pixels determined a parameter, and its percentiles over them: the picture's 2nd and
// 98th around the summary's. Each is the value a full sort would put at its place; nth_element
// finds them in ascending turn, each in what is left above the one before: a tenth of the time
// of sorting.
ParameterSummary summarise(const std::vector<float>& values, const MapBand& band) {
  static_assert(kSummaryPercentiles.front() > 2 && kSummaryPercentiles.back() < 98);
  std::vector<float> determined;
  determined.reserve(values.size());
  for (const float v : values)
    if (!std::isnan(v)) determined.push_back(v);
  std::array<int, kSummaryPercentiles.size() + 2> ascending{};
  ascending.front() = 2, ascending.back() = 98;
  std::ranges::copy(kSummaryPercentiles, ascending.begin() + 1);
  std::array<double, ascending.size()> found{};
  found.fill(std::numeric_limits<double>::quiet_NaN());
  auto from = determined.begin();
  for (std::size_t i = 0; i < ascending.size() && !determined.empty(); ++i) {
    const auto at = determined.begin() +
                    static_cast<std::ptrdiff_t>((determined.size() - 1) * static_cast<std::size_t>(ascending[i]) / 100);
    std::nth_element(from, at, determined.end());
    found[i] = static_cast<double>(*at);
    from = at;
  }
  ParameterSummary summary{band, determined.size(), {}, {found.front(), found.back()}};
  std::copy_n(found.begin() + 1, kSummaryPercentiles.size(), summary.percentiles.begin());
  return summary;
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
  const bool envi = format == MapFormat::envi;
  const fs::path answer_file = state->partial / (name + (envi ? ".map.img" : ".map.tif"));
  auto answers = gdal_io::io().create_answer_file(answer_file, cube, bands, envi);
  if (!answers) return std::unexpected(answers.error());
  state->cube = std::move(*answers);
  return MapWriter(std::move(state));
}

std::expected<void, std::string> MapWriter::write_lines(std::size_t first, std::size_t count,
                                                        std::span<const float> answers) {
  return state_->cube->write_lines(first, count, answers);
}

std::expected<std::vector<ParameterSummary>, std::string> MapWriter::close(ModelKind model, bool pictures) {
  if (auto reopened = state_->cube->close_and_reopen(); !reopened) return std::unexpected(reopened.error());
  const auto mask = state_->cube->read_band(static_cast<int>(state_->bands));
  if (!mask) return std::unexpected(mask.error());
  const auto bands = map_bands(model);
  const std::size_t count = model_spec(model).params.size();
  std::vector<ParameterSummary> summaries(count);
  std::vector<std::expected<std::vector<unsigned char>, std::string>> drawn(count);
  // The parameters two at a time, each read (one at a time: GDAL's files are not shared
  // between threads), summed up and drawn. Two, whatever the cores, because each holds its
  // band, its picture and its PNG: about 95 MB for a 2048 x 2048 cube.
  constexpr unsigned kAtOnce = 2;
  std::mutex reading;
  parallel_for(count, kAtOnce, [&](std::size_t p) {
    std::expected<std::vector<float>, std::string> values;
    {
      const std::lock_guard lock(reading);
      values = state_->cube->read_band(static_cast<int>(2 * p + 1));
    }
    if (!values) {
      drawn[p] = std::unexpected(values.error());
      return;
    }
    summaries[p] = summarise(*values, bands[2 * p]);
    if (pictures)
      drawn[p] =
          render::encode_png(parameter_picture(*values, *mask, state_->cube->lines(), state_->samples, bands[2 * p],
                                               summaries[p].picture_range[0], summaries[p].picture_range[1]),
                             8, render::PngContent::false_colour);
  });
  for (std::size_t p = 0; p < count; ++p) {
    if (!drawn[p]) return std::unexpected(drawn[p].error());
    if (!pictures) continue;
    const fs::path png = state_->partial / fmt::format("{}.{}.png", state_->name.string(), bands[2 * p].name);
    std::ofstream out(png, std::ios::binary);
    out.write(reinterpret_cast<const char*>(drawn[p]->data()), static_cast<std::streamsize>(drawn[p]->size()));
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
