// The store on each engine, durable, on the build machine's disk: committed
// measurement-plus-fit transactions per second (each one on the disk before it returns: SQLite
// with synchronous=FULL, PostgreSQL with fsync and synchronous_commit on, over its Unix socket)
// from one and two threads, and fit reads per second while a writer keeps committing.
// Run: build/release/bin/store_bench. The SQLite file and the PostgreSQL cluster (a throwaway
// one, started here) go to $TMPDIR (or /tmp): put it on the disk you mean to measure. The
// disk's own fdatasync time is printed first, as what bounds a commit.

#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <thread>

#include "skinspec/store/store.hpp"
#include "support/postgres_cluster.hpp"

namespace skinspec::store {
namespace {

std::filesystem::path temporary_directory() {
  std::string pattern = (std::filesystem::temp_directory_path() / "skinspec-bench-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) std::abort();
  return pattern;
}

// One durable cluster for the program's PostgreSQL runs, on the temporary directory's disk.
testing::PostgresCluster& cluster() {
  static testing::PostgresCluster durable(testing::ClusterSettings{.durable = true, .base = {}});
  return durable;
}

// benchmark's argument 0: the engine.
Backend backend_of_run(const benchmark::State& state) {
  return state.range(0) == 0 ? Backend::sqlite : Backend::postgresql;
}

// A fresh database (a file in its own temporary directory, or a new PostgreSQL database) with
// one open session.
struct Scratch {
  std::filesystem::path dir;
  std::optional<Store> store;
  Id session = 0;

  explicit Scratch(Backend backend) {
    std::string target;
    if (backend == Backend::sqlite) {
      dir = temporary_directory();
      target = (dir / "bench.db").string();
    } else {
      target = cluster().uri(cluster().create_database("bench"));
    }
    auto opened = Store::open(target);
    if (!opened) {
      std::fprintf(stderr, "store_bench: %s\n", opened.error().message.c_str());
      std::exit(1);
    }
    store.emplace(std::move(*opened));
    Session s;
    s.subject = "S-1";
    s.site = "forearm";
    s.model = "extended";
    session = *store->create_session(s);
  }
  ~Scratch() {
    store.reset();
    if (!dir.empty()) std::filesystem::remove_all(dir);
  }
};

// What the daemon stores per sample: 101-point radiance, its deviation and the reflectance,
// the meter's reply (about 2 KB), and a fit with its measured and fitted curves.
Measurement measurement(Id session, int n) {
  Measurement m;
  m.session_id = session;
  m.label = "sample";
  m.quality = "OK";
  m.units = "W/(sr m2 nm)";
  m.settings = R"({"integration_ms":0,"averages":3})";
  m.reading_count = 3;
  for (int w = 380; w <= 780; w += 4) {
    const double x = w + n;
    m.radiance.wavelength_nm.push_back(w);
    m.radiance.values.push_back(0.01 + std::sin(x / 50) * 1e-3);
    m.reflectance.wavelength_nm.push_back(w);
    m.reflectance.values.push_back(0.4 + std::cos(x / 60) * 0.1);
  }
  m.radiance_sd = m.radiance;
  m.raw_reply = std::string(1950, '0');
  return m;
}

Fit fit() {
  Fit f;
  f.site = "forearm";
  f.model = "extended";
  f.params = {{"surface_reflectance", 0.05, 0.002}, {"melanin", 7, 0.2},   {"total_hemoglobin", 10, 0.8},
              {"oxygen_saturation", 0.7, 0.05},     {"bilirubin", 1, 0.3}, {"dermis_scattering", 40, 3},
              {"dermis_scattering_power", 1.5, 0.2}};
  f.solver_summary = "CONVERGENCE";
  f.model_version = "skinspec 0.1.0";
  f.tables_digest = "0123456789abcdef";
  for (int w = 380; w <= 780; w += 4) {
    f.wavelength_nm.push_back(w);
    f.measured.push_back(0.4);
    f.fitted.push_back(0.41);
  }
  return f;
}

// Commits from state.threads() threads into one Store (its writes are serialised on one
// connection; PostgreSQL's group commit can share a WAL flush only between connections).
void BM_CommitMeasurementWithFit(benchmark::State& state) {
  static std::unique_ptr<Scratch> scratch;
  static std::atomic<int> ready;
  if (state.thread_index() == 0) {
    scratch = std::make_unique<Scratch>(backend_of_run(state));
    ready = 1;
  }
  while (ready.load() == 0) std::this_thread::yield();
  const auto f = fit();
  int n = state.thread_index() * 1'000'000;
  for (auto _ : state) {
    auto ids = scratch->store->record_measurement(measurement(scratch->session, n++), f);
    if (!ids) state.SkipWithError(ids.error().message.c_str());
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(backend_of_run(state) == Backend::sqlite ? "sqlite" : "postgresql");
  if (state.thread_index() == 0) {
    scratch.reset();
    ready = 0;
  }
}
BENCHMARK(BM_CommitMeasurementWithFit)
    ->ArgName("postgresql")
    ->Arg(0)
    ->Arg(1)
    ->Threads(1)
    ->Threads(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Commits from state.threads() benches at once into one PostgreSQL database, each thread a
// Store of its own bench (as each bench's skinspecd writes): the server may share one WAL
// flush between their commits (a SQLite file has one writer, so it has no such run).
void BM_CommitOnEachBench(benchmark::State& state) {
  static std::string target;
  static std::atomic<int> ready;
  if (state.thread_index() == 0) {
    target = cluster().uri(cluster().create_database("benches"));
    ready = 1;
  }
  while (ready.load() == 0) std::this_thread::yield();
  OpenOptions options;
  options.bench = "bench-" + std::to_string(state.thread_index());
  auto store = Store::open(target, options);
  if (!store) {
    state.SkipWithError(store.error().message.c_str());
    return;
  }
  Session s;
  s.subject = "S-" + options.bench;
  s.site = "forearm";
  s.model = "extended";
  const Id session = *store->create_session(s);
  const auto f = fit();
  int n = 0;
  for (auto _ : state) {
    auto ids = store->record_measurement(measurement(session, n++), f);
    if (!ids) state.SkipWithError(ids.error().message.c_str());
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("postgresql");
  if (state.thread_index() == 0) ready = 0;
}
BENCHMARK(BM_CommitOnEachBench)->Threads(1)->Threads(2)->Threads(4)->Unit(benchmark::kMillisecond)->UseRealTime();

// Reads of stored fits (what GET /api/v1/fits/{id} does) on `state.range(0)` reader threads,
// while another thread commits measurement-plus-fit transactions as fast as it can.
void BM_ReadFitWhileWriting(benchmark::State& state) {
  static std::unique_ptr<Scratch> scratch;
  static std::atomic<bool> stop;
  static std::atomic<long> commits;
  static std::thread writer;
  static std::vector<Id> fits;
  static std::chrono::steady_clock::time_point started;
  if (state.thread_index() == 0) {
    scratch = std::make_unique<Scratch>(backend_of_run(state));
    fits.clear();
    for (int n = 0; n < 200; ++n)
      fits.push_back(*scratch->store->record_measurement(measurement(scratch->session, n), fit())->fit_id);
    stop = false;
    commits = 0;
    writer = std::thread([] {
      const auto f = fit();
      for (int n = 0; !stop; ++n)
        if (scratch->store->record_measurement(measurement(scratch->session, n), f)) ++commits;
    });
    started = std::chrono::steady_clock::now();
  }
  std::mt19937 random(static_cast<unsigned>(state.thread_index()));
  std::uniform_int_distribution<std::size_t> pick(0, 199);
  for (auto _ : state) {
    auto read = scratch->store->fit(fits[pick(random)]);
    if (!read) state.SkipWithError(read.error().message.c_str());
    benchmark::DoNotOptimize(read);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(backend_of_run(state) == Backend::sqlite ? "sqlite" : "postgresql");
  if (state.thread_index() == 0) {
    stop = true;
    writer.join();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    state.counters["writer_commits_per_s"] = static_cast<double>(commits.load()) / seconds;
    scratch.reset();
  }
}
BENCHMARK(BM_ReadFitWhileWriting)
    ->ArgName("postgresql")
    ->Arg(0)
    ->Arg(1)
    ->Threads(1)
    ->Threads(2)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// What one fdatasync of a 4 KiB write takes on the temporary directory's disk, median of 200:
// no durable commit on this disk can be quicker.
double fdatasync_median_ms() {
  const auto dir = temporary_directory();
  const auto path = dir / "sync";
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT, 0600);
  if (fd < 0) std::abort();
  const std::string page(4096, 'x');
  std::vector<double> ms;
  for (int i = 0; i < 200; ++i) {
    const auto start = std::chrono::steady_clock::now();
    if (::pwrite(fd, page.data(), page.size(), 0) != static_cast<ssize_t>(page.size()) || ::fdatasync(fd) != 0)
      std::abort();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  ::close(fd);
  std::filesystem::remove_all(dir);
  std::nth_element(ms.begin(), ms.begin() + 100, ms.end());
  return ms[100];
}

}  // namespace
}  // namespace skinspec::store

int main(int argc, char** argv) {
  std::printf("fdatasync of 4 KiB on %s: median %.3f ms\n", std::filesystem::temp_directory_path().c_str(),
              skinspec::store::fdatasync_median_ms());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
