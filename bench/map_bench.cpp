// Skin maps (maps/): a synthetic skin cube from the forward model, 101 bands on 380-780 nm,
// smooth maps of every parameter and noise of 0.002, mapped as `skinspec map` maps it (read in
// blocks, judged, fitted from the neighbours, written, read back for the summary and pictures),
// and beside it the same pixels fitted one by one from the coarse search on every core, as
// fit_bench's FitBatch fits its spectra. The ratio is what the neighbour starts are worth.
// Goals (docs/maps.md): >= 100,000 pixels/s on 2 cores for 512 x 512; with --lines 2048
// --samples 2048 --bands 200 (a 3.4 GB cube) a resident memory of at most 512 MB.
// Run: build/release/bin/map_bench [--lines N] [--samples N] [--bands N] [--no-batch]
// With --write-cube DIR it only writes the cube (DIR/cube.hdr), so that the memory of
// `skinspec map` alone can be measured on it (docs/benchmarks.md gives the command).

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "fitter_loader.hpp"
#include "skinspec/maps/map_run.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Args {
  std::size_t lines = 512, samples = 512, bands = 101;
  bool batch = true;
  std::string write_cube;  // only write the cube into this directory, for `skinspec map` to map
};

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

long max_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;
}

// The skin at (line, sample): every parameter varies smoothly over the image.
Params skin_at(std::size_t line, std::size_t sample, const Args& a) {
  const double x = static_cast<double>(sample) / static_cast<double>(a.samples),
               y = static_cast<double>(line) / static_cast<double>(a.lines);
  Params p(kExtendedParamCount);
  p[kSurfaceReflectance] = 0.035 + 0.02 * y;
  p[kMelanin] = 2 + 18 * x;
  p[kTotalHemoglobin] = 4 + 8 * y;
  p[kOxygenSaturation] = 0.5 + 0.3 * (x + y) / 2;
  p[kBilirubin] = 0.5;
  p[kDermisScattering] = 25 + 10 * x * y;
  p[kDermisScatteringPower] = 1.0 + 0.8 * y;
  return p;
}

// Writes the cube as ENVI BIL float32. A cube taller than 64 lines repeats its first 64 (with
// fresh noise): the forward model for 4 million pixels would take longer than mapping them.
fs::path write_cube(const fs::path& dir, const Fitter& fitter, const Args& a) {
  const std::vector<double> grid = Spectrum::uniform_grid(380, 780, 400.0 / static_cast<double>(a.bands - 1));
  const SkinOptics& optics = fitter.optics(ModelKind::extended);
  const SkinModel model(optics, *optics.site("forearm"), grid, true);
  const std::size_t distinct = std::min<std::size_t>(a.lines, 64);
  std::vector<float> block(distinct * a.bands * a.samples);  // BIL: line, band, sample
  parallel_for(distinct, 0, [&](std::size_t l) {
    for (std::size_t s = 0; s < a.samples; ++s) {
      const Params p = skin_at(l * a.lines / distinct, s, a);
      for (std::size_t b = 0; b < a.bands; ++b)
        block[(l * a.bands + b) * a.samples + s] = static_cast<float>(model.reflectance_at(b, p.data()));
    }
  });
  std::mt19937 random(512);
  std::normal_distribution noise(0.0, 0.002);
  std::ofstream raw(dir / "cube.img", std::ios::binary);
  std::vector<float> noisy(block.size());
  for (std::size_t first = 0; first < a.lines; first += distinct) {
    const std::size_t count = std::min(distinct, a.lines - first);
    for (std::size_t i = 0; i < count * a.bands * a.samples; ++i)
      noisy[i] = block[i] + static_cast<float>(noise(random));
    raw.write(reinterpret_cast<const char*>(noisy.data()),
              static_cast<std::streamsize>(count * a.bands * a.samples * sizeof(float)));
  }
  std::ofstream header(dir / "cube.hdr");
  header
      << "ENVI\nsamples = " << a.samples << "\nlines = " << a.lines << "\nbands = " << a.bands
      << "\nheader offset = 0\ndata type = 4\ninterleave = bil\nbyte order = 0\nwavelength units = nm\nwavelength = {";
  for (std::size_t b = 0; b < a.bands; ++b) header << (b ? ", " : "") << grid[b];
  header << "}\n";
  return dir / "cube.hdr";
}

struct Mapped {
  double seconds = 0;  // the cube opened, mapped and everything written (maps::run_map)
  maps::MapTimings timings;
  maps::MapTally tally;
};

// As `skinspec map` maps it, with its defaults.
Mapped map(const fs::path& header, const fs::path& out, const Fitter& fitter) {
  const auto start = Clock::now();
  auto cube = maps::Cube::open(header.string());
  if (!cube) throw std::runtime_error(cube.error().what());
  const auto run = maps::run_map(fitter, *cube, "cube", out, maps::MapRunOptions{});
  if (!run) throw std::runtime_error(run.error().message);
  return {seconds_since(start), run->timings, run->tally};
}

// Loads GDAL and its hundred-odd libraries, as a process's first cube does (the service loads
// them once): timed apart, so that the map's time is the same whether it runs first or not.
double gdal_loading_seconds(const fs::path& header) {
  const auto start = Clock::now();
  if (auto cube = maps::Cube::open(header.string()); !cube) throw std::runtime_error(cube.error().what());
  return seconds_since(start);
}

// The same pixels fitted one by one from the coarse search, on every core (FitBatch's way).
double batch_seconds(const fs::path& header, const Fitter& fitter) {
  auto cube = maps::Cube::open(header.string());
  if (!cube) throw std::runtime_error(cube.error().what());
  const auto& info = cube->info();
  const auto values = cube->read_lines(0, info.lines);
  if (!values) throw std::runtime_error(values.error().what());
  std::vector<Spectrum> spectra;
  for (std::size_t p = 0; p < info.lines * info.samples; ++p)
    spectra.push_back(*Spectrum::create(
        info.wavelength_nm, std::vector<double>(values->begin() + static_cast<std::ptrdiff_t>(p * info.bands),
                                                values->begin() + static_cast<std::ptrdiff_t>((p + 1) * info.bands))));
  FitOptions options;
  (void)fitter.fit(spectra.front(), options);  // the model prepared for the grid, as in FitBatch
  const auto start = Clock::now();
  parallel_for(spectra.size(), 0, [&](std::size_t i) { (void)fitter.fit(spectra[i], options); });
  return seconds_since(start);
}

int run(const Args& args) {
  auto fitter = load_fitter();
  if (!fitter) {
    std::fprintf(stderr, "map_bench: %s (set SKINSPEC_DATA_DIR)\n", fitter.error().c_str());
    return 1;
  }
  if (!args.write_cube.empty()) {
    fs::create_directories(args.write_cube);
    std::printf("%s\n", write_cube(args.write_cube, *fitter, args).c_str());
    return 0;
  }
  const fs::path dir = fs::temp_directory_path() / ("map_bench-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path header = write_cube(dir, *fitter, args);
  const double pixels = static_cast<double>(args.lines * args.samples);
  const double loading = gdal_loading_seconds(header);
  const long rss_before = max_rss_mib();
  const Mapped mapped = map(header, dir / "out", *fitter);
  const long rss_map = max_rss_mib();
  std::printf("{\"lines\": %zu, \"samples\": %zu, \"bands\": %zu, \"threads\": %u,\n", args.lines, args.samples,
              args.bands, detail::thread_count(0));
  std::printf(
      " \"gdal_loading_seconds\": %.3f, \"map_seconds\": %.3f, \"fitting_seconds\": %.3f, \"closing_seconds\": %.3f,\n"
      " \"map_pixels_per_second\": %.0f, \"mean_solver_steps\": %.2f,\n",
      loading, mapped.seconds, mapped.timings.fitting, mapped.timings.closing, pixels / mapped.seconds,
      static_cast<double>(mapped.tally.iterations) /
          static_cast<double>(mapped.tally.pixels[static_cast<std::size_t>(maps::MaskReason::skin)]));
  std::printf(" \"max_rss_mib_before_map\": %ld, \"max_rss_mib_after_map\": %ld", rss_before, rss_map);
  if (args.batch) {
    const double batch = batch_seconds(header, *fitter);
    std::printf(",\n \"batch_seconds\": %.3f, \"batch_pixels_per_second\": %.0f, \"map_over_batch_speed\": %.2f", batch,
                pixels / batch, batch / mapped.seconds);
  }
  std::printf("}\n");
  fs::remove_all(dir);
  return 0;
}

}  // namespace
}  // namespace skinspec

int main(int argc, char** argv) {
  skinspec::Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&] { return i + 1 < argc ? std::stoul(argv[++i]) : 0ul; };
    if (a == "--lines") args.lines = next();
    else if (a == "--samples") args.samples = next();
    else if (a == "--bands") args.bands = next();
    else if (a == "--no-batch") args.batch = false;
    else if (a == "--write-cube" && i + 1 < argc) args.write_cube = argv[++i];
    else {
      std::fprintf(stderr, "usage: map_bench [--lines N] [--samples N] [--bands N] [--no-batch] [--write-cube DIR]\n");
      return 2;
    }
  }
  if (args.lines == 0 || args.samples == 0 || args.bands < 2) return 2;
  return skinspec::run(args);
}
