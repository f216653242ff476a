// Forward model, one fit, and a batch of fits on all cores, for each model, on 101-point
// spectra (380-780 nm every 4 nm, the PR-650's native grid), and the memory of a million fits.
// Goals for `extended`, the default (FitOne/extended:1, FitBatch/extended:1, FitMillion):
// one fit median <= 150 us; batch >= 25,000 spectra/s on 2 cores; memory flat over 1,000,000
// fits (FitMillion's max_rss_growth_kib near 0).

#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <atomic>
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

ModelKind model_of(const benchmark::State& state) {
  return state.range(0) == 0 ? ModelKind::paper : ModelKind::extended;
}

SkinModel forearm_model(ModelKind kind) {
  return SkinModel(fitter().optics(kind), *fitter().optics(kind).site("forearm"), grid(), true);
}

// A skin of each model: melanin, total blood, oxygen share and bilirubin as given, the other
// parameters at their defaults.
Params skin(ModelKind kind, double melanin, double blood, double oxygen, double bilirubin) {
  if (kind == ModelKind::paper) return {0.04, melanin, blood * oxygen, blood * (1 - oxygen), bilirubin};
  Params p = default_params(kind);
  p[kMelanin] = melanin;
  p[kTotalHemoglobin] = blood;
  p[kOxygenSaturation] = oxygen;
  p[kBilirubin] = bilirubin;
  return p;
}

// Skin from light to dark with noise of 0.002, as a real measurement might be.
std::vector<Spectrum> synthetic_spectra(ModelKind kind, std::size_t count) {
  const SkinModel model = forearm_model(kind);
  std::mt19937 random(42);
  std::uniform_real_distribution<double> melanin(1, 30), blood(1, 8), share(0.5, 0.95), bilirubin(0, 3);
  std::normal_distribution<double> noise(0, 0.002);
  std::vector<Spectrum> spectra;
  for (std::size_t i = 0; i < count; ++i) {
    const double m = melanin(random), b = blood(random), s = share(random), bil = bilirubin(random);
    auto r = model.reflectance(skin(kind, m, b, s, bil));
    for (double& v : r) v += noise(random);
    spectra.push_back(*Spectrum::create(grid(), r));
  }
  return spectra;
}

void ForwardModel(benchmark::State& state) {
  const ModelKind kind = model_of(state);
  const SkinModel model = forearm_model(kind);
  const Params p = skin(kind, 8, 5, 0.8, 1);
  for (auto _ : state) benchmark::DoNotOptimize(model.reflectance(p));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(ForwardModel)->ArgName("extended")->Arg(0)->Arg(1);

void FitOne(benchmark::State& state) {
  const ModelKind kind = model_of(state);
  const auto spectra = synthetic_spectra(kind, 64);
  FitOptions options;
  options.model = kind;
  std::size_t i = 0;
  double iterations = 0;
  for (auto _ : state) {
    auto fit = fitter().fit(spectra[i++ % spectra.size()], options);
    if (fit) iterations += fit->iterations;
    benchmark::DoNotOptimize(fit);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["solver_iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
}
BENCHMARK(FitOne)
    ->ArgName("extended")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

// A fit started from its own answer (FitOptions::start): what a fit costs beyond its solver's
// steps, as a map's pixel started from a neighbour that is nearly the same skin does.
void FitFromAnswer(benchmark::State& state) {
  const ModelKind kind = model_of(state);
  const auto spectra = synthetic_spectra(kind, 64);
  std::vector<FitOptions> started;
  for (const Spectrum& spectrum : spectra) {
    FitOptions options;
    options.model = kind;
    options.start = fitter().fit(spectrum, options)->params;
    started.push_back(options);
  }
  std::size_t i = 0;
  double iterations = 0;
  for (auto _ : state) {
    auto fit = fitter().fit(spectra[i % spectra.size()], started[i % spectra.size()]);
    ++i;
    if (fit) iterations += fit->iterations;
    benchmark::DoNotOptimize(fit);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["solver_iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
}
BENCHMARK(FitFromAnswer)->ArgName("extended")->Arg(1);

void FitBatch(benchmark::State& state) {
  const ModelKind kind = model_of(state);
  const auto spectra = synthetic_spectra(kind, static_cast<std::size_t>(state.range(1)));
  FitOptions options;
  options.model = kind;
  // The model's first fit prepares it for the grid (once per fitter and model, as the service
  // does at its first fit): that is not the batch's time.
  (void)fitter().fit(spectra.front(), options);
  for (auto _ : state) {
    std::vector<std::expected<FitResult, std::string>> results(spectra.size());
    parallel_for(spectra.size(), 0, [&](std::size_t i) { results[i] = fitter().fit(spectra[i], options); });
    benchmark::DoNotOptimize(results);
  }
  state.SetItemsProcessed(state.iterations() * state.range(1));
}
BENCHMARK(FitBatch)
    ->ArgNames({"extended", "spectra"})
    ->Args({0, 10000})
    ->Args({1, 10000})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);

// The largest resident set of the process so far, in KiB.
double max_rss_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss);
}

// A million fits on all cores, each result dropped as soon as it is made, as a long refit or
// import would: the largest resident set after 10,000 fits (everything warmed up) and after a
// million more. Memory is flat when it does not grow.
void FitMillion(benchmark::State& state) {
  constexpr std::size_t kWarmUp = 10'000, kFits = 1'000'000;
  const ModelKind kind = model_of(state);
  const auto spectra = synthetic_spectra(kind, 64);
  FitOptions options;
  options.model = kind;
  std::atomic<std::size_t> failed{0};
  const auto fit_many = [&](std::size_t count) {
    parallel_for(count, 0, [&](std::size_t i) {
      if (!fitter().fit(spectra[i % spectra.size()], options)) ++failed;
    });
  };
  for (auto _ : state) {
    fit_many(kWarmUp);
    const double before = max_rss_kib();
    fit_many(kFits);
    const double after = max_rss_kib();
    state.counters["max_rss_before_kib"] = before;
    state.counters["max_rss_after_kib"] = after;
    state.counters["max_rss_growth_kib"] = after - before;
  }
  if (failed > 0) state.SkipWithError("a fit failed");
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * (kWarmUp + kFits)));
}
BENCHMARK(FitMillion)->ArgName("extended")->Arg(1)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace skinspec

BENCHMARK_MAIN();
