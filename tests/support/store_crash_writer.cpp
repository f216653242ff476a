// Helper for the crash-safety tests. `store_crash_writer DATABASE [READING_MS]` runs measurement
// jobs on the database until it is killed (each job created, started, then, READING_MS later as
// the meter's reading would take, default 1 ms, ended with its measurement and fit in one
// transaction), printing each one's ids only after its commit has returned. Lines:
//   session <session id>
//   committed <measurement id> <fit id> <job id> <n>   (n: the sample number, see store_samples.hpp)
// `store_crash_writer DATABASE import BENCH` opens the database as bench BENCH and imports
// kImportRows measurements of a running import job in batches of kImportBatch; once kStagedRows
// of them are committed (unpublished) it prints `staged <session id> <job id>` and waits to be
// killed.

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>
#include <utility>
#include <vector>

#include "skinspec/store/store.hpp"
#include "skinspec/testkit/store_samples.hpp"

using namespace skinspec::store;

namespace {

template <typename T>
T must(Result<T> result, const char* what) {
  if (!result) {
    std::fprintf(stderr, "store_crash_writer: %s: %s\n", what, result.error().message.c_str());
    std::exit(1);
  }
  return std::move(*result);
}

constexpr int kImportBatch = 50;
constexpr int kImportRows = 400;
constexpr int kStagedRows = 200;

[[noreturn]] void run_measurement_jobs(Store& store, int reading_ms) {
  const Id session = must(store.create_session(skinspec::testing::sample_session(1)), "session");
  std::printf("session %lld\n", static_cast<long long>(session));
  std::fflush(stdout);
  for (int n = 0;; ++n) {
    Job job;
    job.kind = "measure";
    job.session_id = session;
    const Id job_id = must(store.create_job(job), "job").job.id;
    must(store.update_job(job_id, {.state = JobState::running}), "job start");
    // A job runs for as long as its reading takes: kills land there as often as elsewhere (the
    // job's end, one round trip on PostgreSQL, is too short a stretch of the cycle otherwise).
    std::this_thread::sleep_for(std::chrono::milliseconds(reading_ms));
    const auto done = must(store.complete_measurement_job(job_id, skinspec::testing::sample_measurement(session, n),
                                                          skinspec::testing::sample_fit(n), R"({"readings":1})"),
                           "job end");
    std::printf("committed %lld %lld %lld %d\n", static_cast<long long>(done.ids.measurement_id),
                static_cast<long long>(*done.ids.fit_id), static_cast<long long>(job_id), n);
    std::fflush(stdout);
  }
}

// An import killed between its batches: its source waits, once kStagedRows rows were taken (and
// committed: each batch is written before the next is taken), for the kill that never lets it
// publish.
[[noreturn]] void import_until_killed(Store& store) {
  const Id session = must(store.create_session(skinspec::testing::sample_session(1)), "session");
  Job job;
  job.kind = "import";
  job.session_id = session;
  const Id job_id = must(store.create_job(job), "job").job.id;
  must(store.update_job(job_id, {.state = JobState::running}), "job start");
  std::vector<std::pair<Measurement, std::optional<Fit>>> rows;
  for (int n = 0; n < kImportRows; ++n)
    rows.emplace_back(skinspec::testing::sample_measurement(session, n), skinspec::testing::sample_fit(n));
  std::size_t given = 0;
  (void)store.record_measurements_as_ready(
      [&]() -> const std::pair<Measurement, std::optional<Fit>>* {
        if (given == kStagedRows) {
          std::printf("staged %lld %lld\n", static_cast<long long>(session), static_cast<long long>(job_id));
          std::fflush(stdout);
          for (;;) std::this_thread::sleep_for(std::chrono::hours(1));
        }
        return &rows[given++];
      },
      JobCompletion{job_id, R"({"imported":400})"});
  std::fprintf(stderr, "store_crash_writer: the import ended before it was killed\n");
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 4 && std::strcmp(argv[2], "import") == 0) {
    OpenOptions options;
    options.bench = argv[3];
    options.import_batch = kImportBatch;
    auto store = must(Store::open(argv[1], options), "open");
    import_until_killed(store);
  }
  int reading_ms = 1;
  const bool reading_ok =
      argc < 3 ||
      (std::from_chars(argv[2], argv[2] + std::strlen(argv[2]), reading_ms).ec == std::errc{} && reading_ms >= 0);
  if (argc < 2 || argc > 3 || !reading_ok) {
    std::fprintf(stderr,
                 "usage: store_crash_writer DATABASE [READING_MS]\n       store_crash_writer DATABASE import BENCH\n");
    return 2;
  }
  auto store = must(Store::open(argv[1]), "open");
  run_measurement_jobs(store, reading_ms);
}
