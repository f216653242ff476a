#include "skinspec/maps/map_run.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

namespace skinspec::maps {

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// Each parameter's unit, how many pixels determined it, and its percentiles over them.
json parameters_json(const std::vector<ParameterSummary>& summaries) {
  json out = json::object();
  for (const auto& p : summaries) {
    const auto number = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
    json entry = {{"unit", p.band.unit},
                  {"determined_pixels", p.determined_pixels},
                  {"picture_range", {number(p.picture_range[0]), number(p.picture_range[1])}}};
    for (std::size_t q = 0; q < kSummaryPercentiles.size(); ++q)
      entry[fmt::format("p{}", kSummaryPercentiles[q])] = number(p.percentiles[q]);
    out[p.band.name] = entry;
  }
  return out;
}

json summary_json(const CubeInfo& info, const MapRunOptions& options, const MapTally& tally,
                  const std::vector<ParameterSummary>& parameters, double seconds) {
  json by_reason = json::object();
  for (const MaskReason reason : kMaskReasons)
    by_reason[std::string(to_string(reason))] = tally.pixels[static_cast<std::size_t>(reason)];
  const std::size_t skin = tally.pixels[static_cast<std::size_t>(MaskReason::skin)];
  return {
      {"cube", options.cube_label.empty() ? info.file : options.cube_label},
      {"model", to_string(options.map.fit.model)},
      {"site", options.map.fit.site},
      {"lines", info.lines},
      {"samples", info.samples},
      {"bands", info.bands},
      {"wavelength_nm", info.wavelength_nm},
      {"pixels", by_reason},
      {"parameters", parameters_json(parameters)},
      {"solver",
       {{"mean_iterations", skin ? static_cast<double>(tally.iterations) / static_cast<double>(skin) : 0.0},
        {"started_from_neighbour", tally.started_from_neighbour},
        {"restarted_from_search", tally.restarted}}},
      {"seconds", seconds},
      {"pixels_per_second", static_cast<double>(info.lines * info.samples) / std::max(seconds, 1e-9)},
  };
}

MapRunError bad_cube(const CubeError& error) { return {MapRunError::Kind::bad_cube, error.what()}; }
MapRunError failed(std::string message) { return {MapRunError::Kind::failed, std::move(message)}; }

}  // namespace

std::optional<double> MapProgress::remaining_s() const {
  if (lines_done == 0) return std::nullopt;
  return seconds * static_cast<double>(lines - lines_done) / static_cast<double>(lines_done);
}

std::expected<MapRun, MapRunError> run_map(const Fitter& fitter, const Cube& cube, const std::string& name,
                                           const std::filesystem::path& dir, const MapRunOptions& options,
                                           const MapObserver& observer) {
  const CubeInfo& info = cube.info();
  if (auto covered = check_coverage(info); !covered) return std::unexpected(bad_cube(covered.error()));
  const Mapper mapper(fitter, options.map, info);
  CubeInfo labelled = info;  // the header's description names the cube as the caller knows it
  if (!options.cube_label.empty()) labelled.file = options.cube_label;
  auto writer = MapWriter::create(dir, name, labelled, map_bands(options.map.fit.model), options.format);
  if (!writer) return std::unexpected(failed(writer.error()));

  std::ofstream reflectance;
  if (!options.reflectance_file.empty()) {
    reflectance.open(options.reflectance_file, std::ios::binary | std::ios::trunc);
    if (!reflectance) return std::unexpected(failed(options.reflectance_file.string() + " cannot be written"));
  }
  MapTally tally;
  const auto started = Clock::now();
  const auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - started).count(); };
  const std::size_t block = std::max<std::size_t>(options.block_lines, 1);
  for (std::size_t first = 0; first < info.lines; first += block) {
    const std::size_t count = std::min(block, info.lines - first);
    auto values = cube.read_lines(first, count);
    if (!values) return std::unexpected(bad_cube(values.error()));
    const auto answers = mapper.map_lines(*values, count, tally);
    if (auto written = writer->write_lines(first, count, answers); !written)
      return std::unexpected(failed(written.error()));
    if (reflectance.is_open()) {
      const auto r = mapper.reflectance_lines(*values);
      if (!reflectance.write(reinterpret_cast<const char*>(r.data()),
                             static_cast<std::streamsize>(r.size() * sizeof(float))))
        return std::unexpected(failed(options.reflectance_file.string() + " cannot be written"));
    }
    if (observer && !observer({first + count, info.lines, seconds()}))
      return MapRun{.stopped = true, .files = {}, .summary_json = {}};
  }
  if (reflectance.is_open() && !reflectance.flush())
    return std::unexpected(failed(options.reflectance_file.string() + " cannot be written"));
  const double mapped_in = seconds();
  const auto parameters = writer->close(options.map.fit.model, options.pictures);
  if (!parameters) return std::unexpected(failed(parameters.error()));
  MapRun run;
  run.summary_json = summary_json(info, options, tally, *parameters, mapped_in).dump(2);
  auto files = writer->finish(run.summary_json);
  if (!files) return std::unexpected(failed(files.error()));
  run.files = std::move(*files);
  return run;
}

}  // namespace skinspec::maps
