// skinspec map CUBE... -o DIR: a skin map of each spectral image (docs/maps.md): every pixel
// judged and fitted, the answers as an ENVI cube with a band per quantity, and a summary.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fmt/format.h>
#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "model_options.hpp"
#include "skinspec/maps/map_writer.hpp"

namespace skinspec::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Exit status of a map stopped by SIGINT, as a shell reports a process it killed.
constexpr int kInterrupted = 130;

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted = true; }

struct MapArgs {
  std::vector<std::string> cubes;
  std::string out;
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  std::size_t block_lines = 32;
  unsigned threads = 0;
  bool no_neighbour_starts = false;
};

// Percentiles of each determined parameter over the skin pixels.
struct Percentiles {
  std::vector<std::vector<float>> values;  // per parameter
  void add(std::span<const float> answers, std::size_t band_count, std::size_t params) {
    for (std::size_t at = 0; at < answers.size(); at += band_count)
      for (std::size_t p = 0; p < params; ++p)
        if (!std::isnan(answers[at + 2 * p])) values[p].push_back(answers[at + 2 * p]);
  }
  nlohmann::json json(ModelKind model) {
    nlohmann::json out = nlohmann::json::object();
    const auto specs = model_spec(model).params;
    for (std::size_t p = 0; p < values.size(); ++p) {
      auto& v = values[p];
      nlohmann::json entry = {{"unit", specs[p].unit}, {"determined_pixels", v.size()}};
      std::ranges::sort(v);
      for (const int q : {5, 25, 50, 75, 95})
        entry[fmt::format("p{}", q)] =
            v.empty() ? nlohmann::json(nullptr) : nlohmann::json(v[(v.size() - 1) * static_cast<std::size_t>(q) / 100]);
      out[std::string(specs[p].name)] = entry;
    }
    return out;
  }
};

void map_cube(const std::string& path, const MapArgs& args) {
  auto cube = maps::Cube::open(path);
  if (!cube) throw Failure{kBadInput, cube.error().what()};
  const maps::CubeInfo& info = cube->info();
  maps::MapOptions options;
  options.fit.model = args.model;
  options.fit.site = args.site;
  options.neighbour_starts = !args.no_neighbour_starts;
  options.threads = args.threads;
  if (auto covered = maps::check_coverage(info); !covered) throw Failure{kBadInput, covered.error().what()};
  const maps::Mapper mapper(fitter(), options, info);
  const auto bands = maps::map_bands(args.model);
  auto writer = maps::MapWriter::create(args.out, fs::path(path).stem().string(), info, bands);
  if (!writer) throw Failure{kFailure, writer.error()};

  maps::MapTally tally;
  Percentiles percentiles{std::vector<std::vector<float>>(model_spec(args.model).params.size())};
  const auto started = Clock::now();
  auto reported = started;
  for (std::size_t first = 0; first < info.lines; first += args.block_lines) {
    if (g_interrupted) throw Failure{kInterrupted, fmt::format("{}: interrupted; nothing was written", path)};
    const std::size_t count = std::min(args.block_lines, info.lines - first);
    auto values = cube->read_lines(first, count);
    if (!values) throw Failure{kBadInput, values.error().what()};
    const auto answers = mapper.map_lines(*values, count, tally);
    percentiles.add(answers, bands.size(), model_spec(args.model).params.size());
    if (auto written = writer->write_lines(first, count, answers); !written) throw Failure{kFailure, written.error()};
    const auto now = Clock::now();
    if (now - reported > std::chrono::seconds(1)) {
      reported = now;
      const double done = static_cast<double>(first + count) / static_cast<double>(info.lines);
      const double seconds = std::chrono::duration<double>(now - started).count();
      std::cerr << fmt::format("skinspec map: {}: {:.0f} % of {} lines, {:.0f} s left\n", path, 100 * done, info.lines,
                               seconds / done - seconds);
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  nlohmann::json by_reason = nlohmann::json::object();
  for (const maps::MaskReason reason : maps::kMaskReasons)
    by_reason[std::string(maps::to_string(reason))] = tally.pixels[static_cast<std::size_t>(reason)];
  const std::size_t skin = tally.pixels[static_cast<std::size_t>(maps::MaskReason::skin)];
  const nlohmann::json summary = {
      {"cube", path},
      {"model", to_string(args.model)},
      {"site", args.site},
      {"lines", info.lines},
      {"samples", info.samples},
      {"bands", info.bands},
      {"pixels", by_reason},
      {"parameters", percentiles.json(args.model)},
      {"solver",
       {{"mean_iterations", skin ? static_cast<double>(tally.iterations) / static_cast<double>(skin) : 0.0},
        {"started_from_neighbour", tally.started_from_neighbour},
        {"restarted_from_search", tally.restarted}}},
      {"seconds", seconds},
      {"pixels_per_second", static_cast<double>(info.lines * info.samples) / std::max(seconds, 1e-9)},
  };
  auto written = writer->finish(summary.dump(2));
  if (!written) throw Failure{kFailure, written.error()};
  for (const auto& file : *written) std::cout << file.string() << '\n';
}

}  // namespace

void add_map_command(CLI::App& app) {
  auto args = std::make_shared<MapArgs>();
  auto* map = app.add_subcommand("map", "fit the skin model to every pixel of spectral images (docs/maps.md)");
  map->add_option("CUBE", args->cubes, "reflectance cubes: ENVI (.hdr), multi-band float TIFF, HDF5")->required();
  map->add_option("-o,--out", args->out, "directory for each cube's NAME.map(.hdr) and NAME.summary.json")->required();
  add_model_option(*map, args->model);
  add_site_option(*map, args->site);
  map->add_option("--block-lines", args->block_lines, "lines read and fitted at a time")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  map->add_option("--threads", args->threads, "threads fitting lines; 0: one per core")->capture_default_str();
  map->add_flag("--no-neighbour-starts", args->no_neighbour_starts,
                "start every pixel's fit from the coarse search instead of its left neighbour's answer");
  map->callback([args] {
    std::signal(SIGINT, on_interrupt);
    for (const auto& cube : args->cubes) map_cube(cube, *args);
  });
}

}  // namespace skinspec::cli
