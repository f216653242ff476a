#include "skinspec/maps/map_run.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <future>
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

using Lines = std::expected<std::vector<float>, CubeError>;

// Reads a cube's blocks of lines one ahead, each on a thread of its own, while the block
// before is fitted: read in turn, the blocks of a 512 x 512 cube kept a core idle for 0.2 s of
// the map's 3.1 s. One read at a time, since a cube is read by one thread at once; a reader
// destroyed waits for its read to end.
class ReadAhead {
 public:
  ReadAhead(const Cube& cube, std::size_t block) : cube_(cube), block_(block) { begin(0); }

  // The block that starts at `first` (the one after the last taken), and the next one begun.
  Lines take(std::size_t first) {
    Lines lines = pending_.get();
    if (first + block_ < cube_.info().lines) begin(first + block_);
    return lines;
  }
  // A block's values, done with: the next read goes into their memory.
  void give_back(std::vector<float> values) { spare_ = std::move(values); }

 private:
  void begin(std::size_t first) {
    const std::size_t count = std::min(block_, cube_.info().lines - first);
    pending_ = std::async(std::launch::async, [this, first, count, values = std::move(spare_)]() mutable -> Lines {
      if (auto read = cube_.read_lines(first, count, values); !read) return std::unexpected(read.error());
      return std::move(values);
    });
  }

  const Cube& cube_;
  const std::size_t block_;
  std::vector<float> spare_;
  std::future<Lines> pending_;
};

using Written = std::expected<void, MapRunError>;

// A block of lines fitted, with the values it was fitted from.
struct FittedBlock {
  std::size_t first = 0, count = 0;
  std::vector<float> values, answers;
  MapTally tally;
};

// Fits a block on threads of its own (Mapper::map_lines). Two blocks are fitted at once: as a
// block's threads run out of lines one by one, waiting on its slowest line, the next block's
// take the cores they leave (3 % of the fitting, on two cores, had been such waits).
std::future<FittedBlock> fit_block(const Mapper& mapper, std::size_t first, std::size_t count,
                                   std::vector<float> values) {
  return std::async(std::launch::async, [&mapper, first, count, values = std::move(values)]() mutable {
    FittedBlock block{first, count, std::move(values), {}, {}};
    block.answers = mapper.map_lines(block.values, count, block.tally);
    return block;
  });
}

// Writes each block's answers on a thread of its own while the next block is fitted: written
// in turn, a block's runs of samples (a line of a band each, 608 a block) kept a core idle. One write at a time, in
// order; a write's failure is reported by the next write or by finish(). Destroyed, it waits for its write to end.
class WriteBehind {
 public:
  // Waits for the write before, then begins this one.
  Written write(std::function<Written()> work) {
    if (auto before = finish(); !before) return before;
    pending_ = std::async(std::launch::async, std::move(work));
    return {};
  }
  // Waits for the last write.
  Written finish() { return pending_.valid() ? pending_.get() : Written{}; }

 private:
  std::future<Written> pending_;
};

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
  const bool keeps_reflectance = reflectance.is_open();  // the stream itself is the writes'
  MapRun run;
  const auto started = Clock::now();
  const auto seconds = [](Clock::time_point from) {
    return std::chrono::duration<double>(Clock::now() - from).count();
  };
  const std::size_t block = std::max<std::size_t>(options.block_lines, 1);
  ReadAhead reader(cube, block);
  WriteBehind writes;
  // A block fitted: its answers written behind, its progress told; false where the observer stops
  // the map.
  const auto finish_block = [&](FittedBlock fitted) -> std::expected<bool, MapRunError> {
    run.tally.add(fitted.tally);
    // The block's values go with its answers only where its reflectance is written too (a block
    // of a 2048 x 2048 x 200 cube is 52 MB); else a later read takes their memory.
    std::vector<float> kept;
    if (keeps_reflectance) kept = std::move(fitted.values);
    else reader.give_back(std::move(fitted.values));
    auto write = [&, first = fitted.first, count = fitted.count, answers = std::move(fitted.answers),
                  values = std::move(kept)]() -> Written {
      if (auto written = writer->write_lines(first, count, answers); !written)
        return std::unexpected(failed(written.error()));
      if (!keeps_reflectance) return {};
      const auto r = mapper.reflectance_lines(values);
      if (!reflectance.write(reinterpret_cast<const char*>(r.data()),
                             static_cast<std::streamsize>(r.size() * sizeof(float))))
        return std::unexpected(failed(options.reflectance_file.string() + " cannot be written"));
      return {};
    };
    if (auto written = writes.write(std::move(write)); !written) return std::unexpected(written.error());
    return !observer || observer({fitted.first + fitted.count, info.lines, seconds(started)});
  };
  std::future<FittedBlock> fitting;  // the block before, still being fitted
  for (std::size_t first = 0;; first += block) {
    std::future<FittedBlock> next;
    if (first < info.lines) {
      auto values = reader.take(first);
      if (!values) return std::unexpected(bad_cube(values.error()));
      next = fit_block(mapper, first, std::min(block, info.lines - first), std::move(*values));
    }
    if (fitting.valid()) {
      const auto going_on = finish_block(fitting.get());
      if (!going_on) return std::unexpected(going_on.error());
      if (!*going_on) {
        run.stopped = true;
        return run;
      }
    }
    if (!next.valid()) break;
    fitting = std::move(next);
  }
  run.timings.fitting = seconds(started);
  if (auto written = writes.finish(); !written) return std::unexpected(written.error());
  if (keeps_reflectance && !reflectance.flush())
    return std::unexpected(failed(options.reflectance_file.string() + " cannot be written"));
  const auto closing = Clock::now();
  const double mapped_in = seconds(started);
  const auto parameters = writer->close(options.map.fit.model, options.pictures);
  if (!parameters) return std::unexpected(failed(parameters.error()));
  run.summary_json = summary_json(info, options, run.tally, *parameters, mapped_in).dump(2);
  auto files = writer->finish(run.summary_json);
  if (!files) return std::unexpected(failed(files.error()));
  run.files = std::move(*files);
  run.timings.closing = seconds(closing);
  run.timings.total = seconds(started);
  return run;
}

}  // namespace skinspec::maps
