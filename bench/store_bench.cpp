// The store on each engine, durable, on the build machine's disk: committed
// measurement-plus-fit transactions per second (each one on the disk before it returns: SQLite
// with synchronous=FULL, PostgreSQL with fsync and synchronous_commit on, over its Unix socket)
// from one and two threads, the daemon's own commit at a measuring job's end (the measurement,
// its fit and the job's end), and fit reads per second, alone and while a writer keeps committing;
// beside them PostgreSQL's own pgbench on the same cluster, and at the end the store's rates over
// pgbench's, with what the server's processes spent of the processor on each commit of one
// connection. Run: build/release/bin/store_bench. The SQLite file and the PostgreSQL cluster
// (a throwaway one, started here) go to $TMPDIR (or /tmp): put it on the disk you mean to
// measure. The disk's own fdatasync time is printed first, as what bounds a commit.

#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <thread>

#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/process.hpp"

namespace skinspec::store {
namespace {

// How long each run measures, the store's and pgbench's alike: long enough to take in the
// server's occasional stalls (a new WAL segment every 16 MB) as often in one as in the other.
constexpr int kSeconds = 2;

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

// The processor time the PostgreSQL server has used so far, in seconds (nothing if its
// postmaster cannot be read): the postmaster's own, that of its processes that have ended (it
// waits for each, and the kernel then adds their time to its children's) and that of the live
// ones (backends and background workers; one ended and not yet waited for still shows its
// own). A process waited for during the scan would count twice, so the scan is made again
// until the postmaster's children's time is the same on both sides of it. The kernel counts
// in clock ticks (10 ms here), so a difference over a 2 s run is good to about 10 us a
// transaction.
std::optional<double> server_cpu_seconds() {
  const pid_t server = cluster().server_pid();
  if (server <= 0) return std::nullopt;
  for (;;) {
    const auto before = testing::process_stat(server);
    if (!before) return std::nullopt;
    long long ticks = 0;
    std::error_code ignored;
    for (const auto& entry : std::filesystem::directory_iterator("/proc", ignored)) {
      const auto name = entry.path().filename().string();
      if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
      const auto stat = testing::process_stat(static_cast<pid_t>(std::stol(name)));
      if (stat && stat->parent == server) ticks += stat->own_ticks;
    }
    const auto after = testing::process_stat(server);
    if (!after) return std::nullopt;
    if (after->children_ticks != before->children_ticks) continue;
    return testing::ticks_to_seconds(ticks + after->own_ticks + after->children_ticks);
  }
}

// The server's processor time a transaction over a run, as the counter server_us (left out
// when the server cannot be read); made just before the run's transactions and reported just
// after them.
class ServerTime {
 public:
  ServerTime() : start_(server_cpu_seconds()) {}
  void report(benchmark::State& state, double transactions) const {
    const auto end = server_cpu_seconds();
    if (start_ && end && transactions > 0) state.counters["server_us"] = (*end - *start_) * 1e6 / transactions;
  }

 private:
  std::optional<double> start_;
};

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

// A started job in `session` for each iteration to come, made before the timing starts: each
// timed commit is then the daemon's own at the end of a measuring job, the measurement, its fit
// and the job's end in one transaction. (A job's creation and start are commits of their own,
// made while the meter is still to read.) On a failure the run is marked skipped, so that its
// loop does not run.
std::vector<Id> started_jobs(benchmark::State& state, Store& store, Id session) {
  std::vector<Id> jobs;
  for (benchmark::IterationCount i = 0; i < state.max_iterations; ++i) {
    Job job;
    job.kind = "measure";
    job.session_id = session;
    const auto created = store.create_job(job);
    if (!created) {
      state.SkipWithError(created.error().message.c_str());
      break;
    }
    const auto started = store.update_job(created->job.id, {.state = JobState::running});
    if (!started) {
      state.SkipWithError(started.error().message.c_str());
      break;
    }
    jobs.push_back(started->id);
  }
  return jobs;
}

// Ends each of `jobs` in turn with a measurement and its fit, one per iteration.
void end_jobs(benchmark::State& state, Store& store, Id session, const std::vector<Id>& jobs) {
  const auto f = fit();
  std::size_t next = 0;
  std::optional<ServerTime> server;
  if (backend_of_run(state) == Backend::postgresql) server.emplace();
  for (auto _ : state) {
    const Id job = jobs[next];
    auto done =
        store.complete_measurement_job(job, measurement(session, static_cast<int>(next++)), f, R"({"readings":3})");
    if (!done) {
      state.SkipWithError(done.error().message.c_str());
      break;
    }
  }
  if (server) server->report(state, static_cast<double>(next));
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
  // One thread's run alone: the server's time is then its transactions'.
  std::optional<ServerTime> server;
  if (backend_of_run(state) == Backend::postgresql && state.threads() == 1) server.emplace();
  for (auto _ : state) {
    auto ids = scratch->store->record_measurement(measurement(scratch->session, n++), f);
    if (!ids) {
      state.SkipWithError(ids.error().message.c_str());
      break;
    }
  }
  if (server) server->report(state, static_cast<double>(state.iterations()));
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
    ->MinTime(kSeconds)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The daemon's commit at the end of each measuring job: the measurement, its fit and the job's
// end (succeeded, its result naming them) in one transaction.
void BM_CommitJobEnd(benchmark::State& state) {
  Scratch scratch(backend_of_run(state));
  end_jobs(state, *scratch.store, scratch.session, started_jobs(state, *scratch.store, scratch.session));
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(backend_of_run(state) == Backend::sqlite ? "sqlite" : "postgresql");
}
BENCHMARK(BM_CommitJobEnd)
    ->ArgName("postgresql")
    ->Arg(0)
    ->Arg(1)
    ->MinTime(kSeconds)
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
    if (!ids) {
      state.SkipWithError(ids.error().message.c_str());
      break;
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("postgresql");
  if (state.thread_index() == 0) ready = 0;
}
BENCHMARK(BM_CommitOnEachBench)
    ->Threads(1)
    ->Threads(2)
    ->Threads(4)
    ->MinTime(kSeconds)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// PostgreSQL's own client, pgbench, on the same cluster in the same run: what the server and
// this machine allow apart from the store. Its writes are as many bytes as a measurement and its
// fit (a 7,000- and a 4,000-byte row, kept whole in their pages as the store's are), made by
// the server and committed by one statement in one round trip: a bound that a client, which
// sends its bytes, does not reach. Its reads are of one 4,000-byte row by key, prepared, as
// the store reads a fit.
constexpr std::string_view kReferenceTables = R"sql(
CREATE TABLE measurement_bytes (id bigint GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY,
  session_id bigint NOT NULL, body bytea NOT NULL) WITH (toast_tuple_target = 8160);
CREATE INDEX ON measurement_bytes (session_id);
CREATE TABLE fit_bytes (id bigint GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY,
  measurement_id bigint NOT NULL, body bytea NOT NULL) WITH (toast_tuple_target = 8160);
CREATE INDEX ON fit_bytes (measurement_id);
ALTER TABLE measurement_bytes ALTER body SET STORAGE EXTERNAL;
ALTER TABLE fit_bytes ALTER body SET STORAGE EXTERNAL;
INSERT INTO fit_bytes (measurement_id, body) SELECT n, decode(repeat('66', 4000), 'hex') FROM generate_series(1, 200) n;
)sql";

constexpr std::string_view kReferenceCommit =
    "WITH m AS (INSERT INTO measurement_bytes (session_id, body) VALUES (1, decode(repeat('6d', 7000), 'hex')) "
    "RETURNING id) INSERT INTO fit_bytes (measurement_id, body) SELECT id, decode(repeat('66', 4000), 'hex') FROM m;\n";

constexpr std::string_view kReferenceRead = "\\set id random(1, 200)\nSELECT body FROM fit_bytes WHERE id = :id;\n";

constexpr const char* kCommitScript = "commit.sql";
constexpr const char* kReadScript = "read.sql";

// The reference's database (as the superuser) and its two pgbench scripts.
struct PgbenchReference {
  std::string uri;
  std::filesystem::path dir;
  PgbenchReference() : dir(temporary_directory()) {
    const auto database = cluster().create_database("reference");
    cluster().execute(database, std::string(kReferenceTables));
    uri = cluster().uri(database, "admin");
    write_file(dir / kCommitScript, kReferenceCommit);
    write_file(dir / kReadScript, kReferenceRead);
  }
  ~PgbenchReference() { std::filesystem::remove_all(dir); }

  static void write_file(const std::filesystem::path& path, std::string_view text) {
    std::ofstream out(path, std::ios::binary);
    out << text;
    if (!out.flush()) {
      std::fprintf(stderr, "store_bench: cannot write %s\n", path.c_str());
      std::exit(1);
    }
  }
};

const PgbenchReference& pgbench_reference() {
  static const PgbenchReference made;
  return made;
}

// What pgbench printed of a run: its transactions and their rate, or nothing when either is
// missing (the run failed, or printed something else).
struct PgbenchRun {
  long transactions = 0;
  double per_second = 0;
};

std::optional<PgbenchRun> parse_pgbench(std::string_view out) {
  const auto number_after = [&](std::string_view label, auto& value) {
    const auto at = out.find(label);
    if (at == std::string_view::npos) return false;
    const auto text = out.substr(at + label.size());
    return std::from_chars(text.data(), text.data() + text.size(), value).ec == std::errc{};
  };
  PgbenchRun run;
  if (!number_after("number of transactions actually processed: ", run.transactions) ||
      !number_after("tps = ", run.per_second) || run.transactions <= 0 || !(run.per_second > 0))
    return std::nullopt;
  return run;
}

// Runs a pgbench script for kSeconds on state.range(0) connections (and as many threads) as one
// iteration, timed by what pgbench counts: its transactions over their rate. (The Time column
// of these rows is so the whole run; compare their items per second.)
void run_pgbench(benchmark::State& state, const char* script) {
  const auto clients = std::to_string(state.range(0));
  const auto& reference = pgbench_reference();
  testing::ProcessOptions options;
  options.environment = {"LC_ALL=C"};  // a decimal point in its figures whatever the locale
  for (auto _ : state) {
    const ServerTime server;
    const auto run =
        testing::run_process(testing::postgres_program("pgbench"),
                             {"-n", "-M", "prepared", "-c", clients, "-j", clients, "-T", std::to_string(kSeconds),
                              "-f", (reference.dir / script).string(), reference.uri},
                             options);
    const auto parsed = run.exited() && run.exit_status == 0 ? parse_pgbench(run.out) : std::nullopt;
    if (!parsed) {
      state.SkipWithError(("pgbench: " + run.describe()).c_str());
      break;
    }
    state.SetIterationTime(static_cast<double>(parsed->transactions) / parsed->per_second);
    state.SetItemsProcessed(parsed->transactions);
    // Its connection's backend ends after pgbench has exited: the work of that end is counted too.
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    server.report(state, static_cast<double>(parsed->transactions));
  }
  state.SetLabel("pgbench");
}

void BM_PgbenchCommit(benchmark::State& state) { run_pgbench(state, kCommitScript); }
BENCHMARK(BM_PgbenchCommit)
    ->ArgName("clients")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// Reads of stored fits (what GET /api/v1/fits/{id} does) on state.threads() reader threads:
// alone (argument 1 is 0), or while another thread commits measurement-plus-fit transactions
// as fast as it can (1), so that reads and commits share the processor and the database.
void BM_ReadFit(benchmark::State& state) {
  static std::unique_ptr<Scratch> scratch;
  static std::atomic<bool> stop;
  static std::atomic<long> commits;
  static std::thread writer;
  static std::vector<Id> fits;
  static std::chrono::steady_clock::time_point started;
  const bool writing = state.range(1) != 0;
  if (state.thread_index() == 0) {
    scratch = std::make_unique<Scratch>(backend_of_run(state));
    fits.clear();
    for (int n = 0; n < 200; ++n)
      fits.push_back(*scratch->store->record_measurement(measurement(scratch->session, n), fit())->fit_id);
    stop = false;
    commits = 0;
    if (writing)
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
    if (!read) {
      state.SkipWithError(read.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(read);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(backend_of_run(state) == Backend::sqlite ? "sqlite" : "postgresql");
  if (state.thread_index() == 0) {
    if (writing) {
      stop = true;
      writer.join();
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      state.counters["writer_commits_per_s"] = static_cast<double>(commits.load()) / seconds;
    }
    scratch.reset();
  }
}
BENCHMARK(BM_ReadFit)
    ->ArgNames({"postgresql", "writing"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Threads(1)
    ->Threads(2)
    ->MinTime(kSeconds)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

void BM_PgbenchRead(benchmark::State& state) { run_pgbench(state, kReadScript); }
BENCHMARK(BM_PgbenchRead)
    ->ArgName("clients")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(1)
    ->UseManualTime()
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

// Passes each run on to the usual display, and keeps its items per second by run name (with
// --benchmark_repetitions, a run's median under its own name).
class RateKeepingReporter : public benchmark::BenchmarkReporter {
 public:
  explicit RateKeepingReporter(benchmark::BenchmarkReporter* display) : display_(display) {}
  bool ReportContext(const Context& context) override { return display_->ReportContext(context); }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& run : runs) {
      const auto found = run.counters.find("items_per_second");
      if (found == run.counters.end() || run.error_occurred) continue;
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      if (run.run_type != Run::RT_Iteration && !median) continue;
      rates_[run.run_name.str()] = found->second.value;
      if (const auto server = run.counters.find("server_us"); server != run.counters.end())
        server_us_[run.run_name.str()] = server->second.value;
    }
    display_->ReportRuns(runs);
  }
  void Finalize() override { display_->Finalize(); }

  // The store's rate over pgbench's, for the runs of both that ran. The runs' names are the
  // benchmark library's (with kSeconds in them); a pair of which one side is missing says so.
  void print_comparison() const {
    struct Pair {
      const char* what;
      const char* store;
      const char* pgbench;
    };
    static constexpr Pair kPairs[] = {
        {"commits, one connection", "BM_CommitMeasurementWithFit/postgresql:1/min_time:2.000/real_time/threads:1",
         "BM_PgbenchCommit/clients:1/iterations:1/manual_time"},
        {"job ends, one connection", "BM_CommitJobEnd/postgresql:1/min_time:2.000/real_time",
         "BM_PgbenchCommit/clients:1/iterations:1/manual_time"},
        {"commits, two connections", "BM_CommitOnEachBench/min_time:2.000/real_time/threads:2",
         "BM_PgbenchCommit/clients:2/iterations:1/manual_time"},
        {"reads, one connection", "BM_ReadFit/postgresql:1/writing:0/min_time:2.000/real_time/threads:1",
         "BM_PgbenchRead/clients:1/iterations:1/manual_time"},
        {"reads, two connections", "BM_ReadFit/postgresql:1/writing:0/min_time:2.000/real_time/threads:2",
         "BM_PgbenchRead/clients:2/iterations:1/manual_time"},
    };
    for (const auto& pair : kPairs) {
      const auto store = rates_.find(pair.store);
      const auto pgbench = rates_.find(pair.pgbench);
      if (store == rates_.end() && pgbench == rates_.end()) continue;
      if (store == rates_.end() || pgbench == rates_.end()) {
        std::printf("PostgreSQL %s: only %s ran, nothing to compare\n", pair.what,
                    store == rates_.end() ? pair.pgbench : pair.store);
        continue;
      }
      std::printf("PostgreSQL %s: the store %.0f/s, pgbench %.0f/s: %.2f of pgbench", pair.what, store->second,
                  pgbench->second, store->second / pgbench->second);
      const auto store_server = server_us_.find(pair.store);
      const auto pgbench_server = server_us_.find(pair.pgbench);
      if (store_server != server_us_.end() && pgbench_server != server_us_.end())
        std::printf("; the server's processor time a transaction: the store's %.0f us, pgbench's %.0f us",
                    store_server->second, pgbench_server->second);
      std::printf("\n");
    }
  }

 private:
  benchmark::BenchmarkReporter* display_;
  std::map<std::string, double> rates_;
  std::map<std::string, double> server_us_;  // the server_us counter, where a run has it
};

}  // namespace
}  // namespace skinspec::store

int main(int argc, char** argv) {
  std::printf("fdatasync of 4 KiB on %s: median %.3f ms\n", std::filesystem::temp_directory_path().c_str(),
              skinspec::store::fdatasync_median_ms());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  skinspec::store::RateKeepingReporter reporter(benchmark::CreateDefaultDisplayReporter());
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.print_comparison();
  benchmark::Shutdown();
  return 0;
}
