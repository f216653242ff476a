// Forward model, one fit, and a batch of fits on all cores, on 101-point spectra (380-780 nm
// every 4 nm, the PR-650's native grid). Goals: one fit median <= 1 ms; batch >= 2000/s.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <random>

#include "fitter_loader.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec {
namespace {

const Fitter& fitter() {
  static const Fitter instance = [] {
    auto loaded = load_fitter();
    if (!loaded) {
      std::fprintf(stderr, "fit_bench: %s (set SKINSPEC_DATA_DIR)\n", loaded.error().c_str());
      std::exit(1);
    }
    return std::move(*loaded);
  }();
  return instance;
}

const std::vector<double>& grid() {
  static const auto g = Spectrum::uniform_grid(380, 780, 4);
  return g;
}

// Skin from light to dark with noise of 0.002, as a real measurement might be.
std::vector<Spectrum> synthetic_spectra(std::size_t count) {
  const SkinModel model(fitter().optics(), *fitter().optics().site("forearm"), grid(), true);
  std::mt19937 random(42);
  std::uniform_real_distribution<double> melanin(1, 30), blood(1, 8), share(0.5, 0.95), bilirubin(0, 3);
  std::normal_distribution<double> noise(0, 0.002);
  std::vector<Spectrum> spectra;
  for (std::size_t i = 0; i < count; ++i) {
    const double total = blood(random), oxygen = share(random);
    auto r = model.reflectance({0.04, melanin(random), total * oxygen, total * (1 - oxygen), bilirubin(random)});
    for (double& v : r) v += noise(random);
    spectra.push_back(*Spectrum::create(grid(), r));
  }
  return spectra;
}

void ForwardModel(benchmark::State& state) {
  const SkinModel model(fitter().optics(), *fitter().optics().site("forearm"), grid(), true);
  const Params p{0.04, 8, 4, 1, 1};
  for (auto _ : state) benchmark::DoNotOptimize(model.reflectance(p));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(ForwardModel);

void FitOne(benchmark::State& state) {
  const auto spectra = synthetic_spectra(64);
  const FitOptions options;
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(fitter().fit(spectra[i++ % spectra.size()], options));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(FitOne)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);

void FitBatch(benchmark::State& state) {
  const auto spectra = synthetic_spectra(static_cast<std::size_t>(state.range(0)));
  const FitOptions options;
  for (auto _ : state) {
    std::vector<std::expected<FitResult, std::string>> results(spectra.size());
    parallel_for(spectra.size(), 0, [&](std::size_t i) { results[i] = fitter().fit(spectra[i], options); });
    benchmark::DoNotOptimize(results);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(FitBatch)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace skinspec

BENCHMARK_MAIN();
