// skinspec map CUBE... -o DIR: a skin map of each spectral image (docs/maps.md): every pixel
// judged and fitted, the answers as an ENVI cube with a band per quantity, and a summary.

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cstdlib>
#include <map>
#include <optional>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fmt/format.h>
#include <iostream>

#include "common.hpp"
#include "model_options.hpp"
#include "skinspec/maps/map_run.hpp"

namespace skinspec::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// SIGINT (Ctrl-C) or SIGTERM (a scheduler's time limit, `scancel`) stop a map between blocks of
// lines; it exits with 128 + the signal's number, as a shell reports a process it killed.
std::atomic<int> g_stopped_by{0};
extern "C" void on_stop(int signal) { g_stopped_by = signal; }

struct MapArgs {
  std::vector<std::string> cubes;
  std::string out;
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  std::size_t block_lines = 32;
  unsigned threads = 0;
  bool no_neighbour_starts = false;
  std::string format = "envi";
  std::string shard;  // "I/N"
  // Radiance cubes: the white panel (a cube of its own, or a region of each cube), its
  // calibrated reflectance (a number or a spectra CSV), and a dark cube.
  std::string white, white_roi, white_reflectance = "0.99", dark;
  bool radiance() const { return !white.empty() || !white_roi.empty(); }
};

std::optional<std::size_t> whole_number(std::string_view text) {
  std::size_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

// --white-roi x,y,w,h.
maps::Region region_of(const std::string& text) {
  std::array<std::size_t, 4> v{};
  std::string_view rest = text;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto comma = rest.find(',');
    const auto value = whole_number(rest.substr(0, comma));
    if (!value || (i < 3) == (comma == std::string_view::npos))
      throw Failure{kBadInput, fmt::format("--white-roi {}: expected x,y,w,h in pixels", text)};
    v[i] = *value;
    rest.remove_prefix(comma == std::string_view::npos ? rest.size() : comma + 1);
  }
  if (v[2] == 0 || v[3] == 0) throw Failure{kBadInput, fmt::format("--white-roi {}: an empty region", text)};
  return {v[0], v[1], v[2], v[3]};
}

maps::Cube open_cube(const std::string& path) {
  auto cube = maps::Cube::open(path);
  if (!cube) throw Failure{kBadInput, cube.error().what()};
  return std::move(*cube);
}

std::vector<double> mean_or_refuse(std::expected<std::vector<double>, maps::CubeError> mean) {
  if (!mean) throw Failure{kBadInput, mean.error().what()};
  return std::move(*mean);
}

// The white panel's calibrated reflectance on the cube's bands: one number for every band, or
// a spectra CSV's first spectrum, interpolated.
std::vector<double> white_reflectance_on(const maps::CubeInfo& cube, const std::string& given) {
  double flat = 0;
  const auto [end, error] = std::from_chars(given.data(), given.data() + given.size(), flat);
  if (error == std::errc() && end == given.data() + given.size()) {
    if (!(flat > 0 && flat <= 1)) throw Failure{kBadInput, fmt::format("--white-reflectance {}: not in (0, 1]", given)};
    return std::vector<double>(cube.bands, flat);
  }
  const auto spectra = read_spectra(given);
  const Spectrum& white = spectra.front().spectrum;
  std::vector<double> on_bands;
  for (const double nm : cube.wavelength_nm) {
    if (nm < white.first_nm() || nm > white.last_nm())
      throw Failure{kBadInput,
                    fmt::format("{}: the white's reflectance does not reach {} nm of {}", given, nm, cube.file)};
    on_bands.push_back(white.at(nm));
  }
  return on_bands;
}

std::optional<maps::Radiometry> radiometry_of(const maps::Cube& cube, const MapArgs& args) {
  if (!args.radiance()) {
    if (!args.dark.empty()) throw Failure{kBadInput, "--dark is for radiance cubes: give --white or --white-roi too"};
    return std::nullopt;
  }
  const maps::CubeInfo& info = cube.info();
  const std::vector<double> white =
      mean_or_refuse(args.white.empty() ? maps::mean_spectrum(cube, region_of(args.white_roi))
                                        : maps::panel_spectrum(open_cube(args.white), info));
  const std::vector<double> dark =
      args.dark.empty() ? std::vector<double>{} : mean_or_refuse(maps::panel_spectrum(open_cube(args.dark), info));
  auto r = maps::radiometry(info, white, white_reflectance_on(info, args.white_reflectance), dark);
  if (!r) throw Failure{kBadInput, r.error().what()};
  return std::move(*r);
}

// This process's share of the cubes: I of N (0 <= I < N) from --shard, else from a Slurm job
// array's SLURM_ARRAY_TASK_ID (less SLURM_ARRAY_TASK_MIN) and SLURM_ARRAY_TASK_COUNT, else all.
struct Shard {
  std::size_t index = 0, count = 1;
};

Shard shard_of(const std::string& option) {
  Shard shard;
  if (!option.empty()) {
    const auto slash = option.find('/');
    const std::string_view text(option);
    // A missing or malformed I or N reads as an empty share, which is refused.
    const std::size_t count = slash == std::string::npos ? 0 : whole_number(text.substr(slash + 1)).value_or(0);
    const std::size_t index = whole_number(text.substr(0, slash)).value_or(count);
    if (index >= count) throw Failure{kBadInput, fmt::format("--shard {}: expected I/N with 0 <= I < N", option)};
    return {index, count};
  }
  const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
  const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
  if (!id || !count) return shard;
  const char* min = std::getenv("SLURM_ARRAY_TASK_MIN");
  const auto task = whole_number(id), tasks = whole_number(count), first = whole_number(min ? min : "0");
  if (!task || !tasks || !first || *tasks == 0 || *task < *first || *task - *first >= *tasks)
    throw Failure{kBadInput, fmt::format("SLURM_ARRAY_TASK_ID={} SLURM_ARRAY_TASK_COUNT={} SLURM_ARRAY_TASK_MIN={}: "
                                         "not a task of the array",
                                         id, count, min ? min : "")};
  return {*task - *first, *tasks};
}

// The cubes of this shard: every Nth of them in sorted order from the Ith, so that the same
// list gives each task the same share whatever order the shell expanded it in.
std::vector<std::string> cubes_of(std::vector<std::string> cubes, const Shard& shard) {
  std::ranges::sort(cubes);
  cubes.erase(std::unique(cubes.begin(), cubes.end()), cubes.end());
  std::vector<std::string> share;
  for (std::size_t i = shard.index; i < cubes.size(); i += shard.count) share.push_back(cubes[i]);
  return share;
}

// Two cubes of one name would write the same files. (The same path twice is one cube.)
void refuse_same_names(const std::vector<std::string>& cubes) {
  std::map<std::string, std::string> by_name;
  for (const auto& cube : cubes) {
    const auto [at, added] = by_name.emplace(fs::path(cube).stem().string(), cube);
    if (!added)
      throw Failure{kBadInput, fmt::format("{} and {} would both be mapped to {}.*", at->second, cube, at->first)};
  }
}

void map_cube(const std::string& path, const MapArgs& args) {
  const auto cube = std::make_unique<maps::Cube>(open_cube(path));
  maps::MapRunOptions options;
  options.map.fit.model = args.model;
  options.map.fit.site = args.site;
  options.map.neighbour_starts = !args.no_neighbour_starts;
  options.map.threads = args.threads;
  options.map.radiance = radiometry_of(*cube, args);
  options.block_lines = args.block_lines;
  options.format = args.format == "tiff" ? maps::MapFormat::tiff : maps::MapFormat::envi;
  options.cube_label = path;
  auto reported = Clock::now();
  const auto observer = [&](const maps::MapProgress& at) {
    if (g_stopped_by != 0) return false;
    if (const auto now = Clock::now(); now - reported > std::chrono::seconds(1)) {
      reported = now;
      std::cerr << fmt::format("skinspec map: {}: {:.0f} % of {} lines, {:.0f} s left\n", path,
                               100.0 * static_cast<double>(at.lines_done) / static_cast<double>(at.lines), at.lines,
                               at.remaining_s().value_or(0));
    }
    return true;
  };
  const auto run = maps::run_map(fitter(), *cube, fs::path(path).stem().string(), args.out, options, observer);
  if (!run)
    throw Failure{run.error().kind == maps::MapRunError::Kind::bad_cube ? kBadInput : kFailure, run.error().message};
  if (run->stopped) {
    const int signal = g_stopped_by;
    throw Failure{128 + signal,
                  fmt::format("{}: stopped by {}; nothing was written", path, signal == SIGINT ? "SIGINT" : "SIGTERM")};
  }
  for (const auto& file : run->files) std::cout << file.string() << '\n';
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
  map->add_option("--threads", args->threads, "threads fitting a block's lines, two blocks at once; 0: one per core")
      ->capture_default_str();
  map->add_flag("--no-neighbour-starts", args->no_neighbour_starts,
                "start every pixel's fit from the coarse search instead of its left neighbour's answer");
  map->add_option("--format", args->format, "the answer cube: envi (NAME.map.img, .hdr) or tiff (NAME.map.tif)")
      ->check(CLI::IsMember({"envi", "tiff"}))
      ->capture_default_str();
  map->add_option("--white", args->white, "for radiance cubes: a cube of the white panel, its mean over every pixel");
  map->add_option("--white-roi", args->white_roi,
                  "for radiance cubes: the white panel as a region x,y,w,h (pixels) of each cube")
      ->excludes("--white");
  map->add_option("--white-reflectance", args->white_reflectance,
                  "the white panel's calibrated reflectance: a number, or a spectra CSV")
      ->capture_default_str();
  map->add_option("--dark", args->dark, "for radiance cubes: a dark cube, its mean subtracted from cube and white");
  map->add_option("--shard", args->shard,
                  "map only share I of N (0 <= I < N) of the cubes, in sorted order; by default a Slurm job "
                  "array's task");
  map->callback([args] {
    refuse_same_names(cubes_of(args->cubes, {}));  // across every shard: they share DIR
    const auto cubes = cubes_of(args->cubes, shard_of(args->shard));
    std::signal(SIGINT, on_stop);
    std::signal(SIGTERM, on_stop);
    if (fs::exists(args->out) && !fs::is_directory(args->out))
      throw Failure{kBadInput, fmt::format("-o {}: not a directory", args->out)};
    for (const auto& cube : cubes) map_cube(cube, *args);
  });
}

}  // namespace skinspec::cli
