// Readers beside a writer, in threads of one process; and a writer process running jobs
// SIGKILLed at random moments, after which the database is intact, holds everything it
// reported committed, and its jobs agree with the rows they stored. Each on a SQLite file and
// on a PostgreSQL database of the test program's throwaway cluster.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include "each_backend.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using Kind = StoreError::Kind;

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

// A new database on the test's engine: a file in a scratch directory, or a PostgreSQL database.
class OnEachBackend : public ::testing::TestWithParam<Backend> {
 protected:
  OnEachBackend()
      : target_(GetParam() == Backend::sqlite
                    ? dir_.file("skinspec.db")
                    : testing::postgres_cluster().uri(testing::postgres_cluster().create_database())) {}
  testing::ScratchDirectory dir_;
  std::string target_;
};
using StoreConcurrencyTest = OnEachBackend;
using StoreCrashTest = OnEachBackend;

INSTANTIATE_TEST_SUITE_P(EachBackend, StoreConcurrencyTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);
INSTANTIATE_TEST_SUITE_P(EachBackend, StoreCrashTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);

// Readers see whole transactions only: every fit they find has its measurement, every
// measurement they find has its fit, and the counts only grow.
TEST_P(StoreConcurrencyTest, ReadersSeeWholeTransactionsWhileOneThreadWrites) {
  OpenOptions options;
  options.max_readers = 3;  // four reader threads: one always waits for a connection
  auto store = value_of(Store::open(target_, options));
  const Id session = value_of(store.create_session(testing::sample_session(1)));

  constexpr int kWrites = 150;
  std::atomic<bool> writing{true};
  std::atomic<int> reads{0};
  std::vector<std::string> problems(4);
  std::vector<std::thread> readers;
  for (std::size_t r = 0; r < problems.size(); ++r) {
    readers.emplace_back([&, r] {
      std::size_t last_count = 0;
      while (writing.load() || reads.load() < 40) {
        const auto detail = store.session_detail(session);
        if (!detail) {
          problems[r] = detail.error().message;
          return;
        }
        if (detail->measurements.size() != detail->fits.size() || detail->measurements.size() < last_count) {
          problems[r] = "a snapshot with " + std::to_string(detail->measurements.size()) + " measurements and " +
                        std::to_string(detail->fits.size()) + " fits";
          return;
        }
        last_count = detail->measurements.size();
        for (const auto& m : detail->measurements) {
          if (auto problem = testing::check_sample_measurement(m); !problem.empty()) {
            problems[r] = problem;
            return;
          }
        }
        ++reads;
      }
    });
  }
  for (int n = 0; n < kWrites; ++n) {
    ASSERT_TRUE(store.record_measurement(testing::sample_measurement(session, n), testing::sample_fit(n)));
  }
  writing = false;
  for (auto& t : readers) t.join();
  for (const auto& problem : problems) EXPECT_EQ(problem, "");
  EXPECT_GE(reads.load(), 40);
  EXPECT_EQ(value_of(store.session_detail(session)).fits.size(), static_cast<std::size_t>(kWrites));
}

// Writes from several threads are serialised on the one writer connection.
TEST_P(StoreConcurrencyTest, WritesFromManyThreadsAllLand) {
  auto store = value_of(Store::open(target_));
  const Id session = value_of(store.create_session(testing::sample_session(1)));
  std::vector<std::thread> writers;
  std::atomic<int> failures{0};
  for (int t = 0; t < 4; ++t) {
    writers.emplace_back([&, t] {
      for (int i = 0; i < 10; ++i) {
        const int n = t * 100 + i;
        if (!store.record_measurement(testing::sample_measurement(session, n), testing::sample_fit(n))) ++failures;
        if (!store.session(session)) ++failures;
      }
    });
  }
  for (auto& t : writers) t.join();
  EXPECT_EQ(failures.load(), 0);
  const auto detail = value_of(store.session_detail(session));
  EXPECT_EQ(detail.measurements.size(), 40u);
  for (const auto& m : detail.measurements) EXPECT_EQ(testing::check_sample_measurement(m), "");
}

struct Reported {
  Id fit_id;
  Id job_id;
  int n;
};

// The complete "committed" lines of the writer's output.
std::map<Id, Reported> committed_lines(const std::string& out) {
  std::map<Id, Reported> found;
  std::istringstream lines(out.substr(0, out.rfind('\n') == std::string::npos ? 0 : out.rfind('\n') + 1));
  for (std::string line; std::getline(lines, line);) {
    long long measurement = 0, fit = 0, job = 0;
    int n = 0;
    if (std::sscanf(line.c_str(), "committed %lld %lld %lld %d", &measurement, &fit, &job, &n) == 4)
      found[measurement] = {fit, job, n};
  }
  return found;
}

// Every reported id, read back through a read-only store: present and whole, its job
// succeeded and naming it.
void expect_reported_present(const std::string& path, const std::map<Id, Reported>& reported) {
  OpenOptions options;
  options.mode = OpenMode::read_only;
  options.check_integrity = false;
  auto store = value_of(Store::open(path, options));
  for (const auto& [measurement_id, r] : reported) {
    const auto m = store.measurement(measurement_id);
    ASSERT_TRUE(m) << "reported measurement " << measurement_id << " is missing: " << m.error().message;
    EXPECT_EQ(testing::check_sample_measurement(*m), "") << "measurement " << measurement_id;
    EXPECT_EQ(m->label, "sample " + std::to_string(r.n));
    EXPECT_EQ(m->job_id, r.job_id);
    const auto f = store.fit(r.fit_id);
    ASSERT_TRUE(f) << "reported fit " << r.fit_id << " is missing";
    EXPECT_EQ(f->measurement_id, measurement_id);
    EXPECT_EQ(testing::check_sample_fit(*f, r.n), "") << "fit " << r.fit_id;
    EXPECT_EQ(value_of(store.job(r.job_id)).state, JobState::succeeded);
  }
}

// The writer is killed anywhere in its cycle, including between a job's start and its end,
// where a measurement and its job's end were once two commits.
TEST_P(StoreCrashTest, AWriterKilledAtRandomMomentsLosesNothingItReported) {
  const auto& path = target_;
  std::mt19937 random(650);
  std::uniform_int_distribution<int> delay_us(0, 60'000);
  std::bernoulli_distribution kill_early(0.2);  // before it has even opened the database
  std::map<Id, Reported> all_reported;
  int kills_mid_stream = 0;

  for (int round = 0; round < 100; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    testing::BackgroundProcess writer(SKINSPEC_TEST_BIN_DIR "/store_crash_writer", {path});
    ASSERT_TRUE(writer.started()) << writer.start_error();
    // Killed either before it has opened the database, or at a random moment of its job loop:
    // after its first commit, however slowly a loaded machine got it there.
    if (!kill_early(random)) {
      ASSERT_TRUE(writer.wait_for_stdout_line("committed ", std::chrono::seconds(60))) << writer.err();
    }
    std::this_thread::sleep_for(std::chrono::microseconds(delay_us(random)));
    writer.send_signal(SIGKILL);
    const auto ended = writer.wait(std::chrono::seconds(10));
    ASSERT_EQ(ended.signal, SIGKILL) << ended.describe();

    const auto reported = committed_lines(ended.out);
    if (!reported.empty()) ++kills_mid_stream;
    all_reported.insert(reported.begin(), reported.end());
    if (GetParam() == Backend::sqlite) {
      ASSERT_EQ(testing::sqlite_text(path, "PRAGMA integrity_check"), "ok");
    }
    EXPECT_EQ(testing::jobs_and_rows_disagreement(path), "");
    EXPECT_EQ(
        testing::raw_database(path)->integer("SELECT count(*) FROM measurements m WHERE m.job_id IS NULL OR NOT EXISTS "
                                             "(SELECT 1 FROM fits f WHERE f.measurement_id = m.id)"),
        0);
    expect_reported_present(path, reported);
    if (HasFatalFailure()) return;
  }
  EXPECT_GE(kills_mid_stream, 60) << "most kills should land while it is writing";
  expect_reported_present(path, all_reported);

  // Every writer's open recovered the one before; this open recovers the last. Every job has
  // succeeded with its rows or failed as interrupted with none, and a session is interrupted
  // exactly when one of its jobs was.
  auto store = value_of(Store::open(path));
  EXPECT_EQ(testing::jobs_and_rows_disagreement(path), "");
  int interrupted = 0;
  for (const auto& s : value_of(store.sessions({.limit = 1000})).sessions) {
    bool any_interrupted = false;
    for (const auto& job : value_of(store.jobs(s.id, 1000))) {
      if (job.state == JobState::succeeded) continue;
      EXPECT_EQ(job.state, JobState::failed) << "job " << job.id;
      ASSERT_TRUE(job.error) << "job " << job.id;
      EXPECT_EQ(job.error->code, JobErrorCode::interrupted) << "job " << job.id;
      any_interrupted = true;
    }
    EXPECT_EQ(s.state, any_interrupted ? SessionState::interrupted : SessionState::open) << "session " << s.id;
    interrupted += any_interrupted;
  }
  EXPECT_GE(interrupted, 30);
  // Killed between a job's start and its end, where the measurement was once committed apart
  // from the job's end.
  const auto killed_while_running = testing::raw_database(path)->integer(
      "SELECT count(*) FROM jobs WHERE state = 'failed' AND started_at IS NOT NULL");
  std::printf("kills mid-stream: %d of 100, of them while a job ran: %lld\n", kills_mid_stream, killed_while_running);
  EXPECT_GE(killed_while_running, 15);
}

// The rows of `table`, whether any read may see them or not.
long long raw_count(const std::string& target, const std::string& table) {
  return testing::raw_database(target)->integer("SELECT count(*) FROM " + table);
}

// A writer killed in the middle of an import, some of its batches committed and none published:
// no read sees anything of it, and the next read-write opening of its bench removes its rows and
// fails its job as interrupted. On PostgreSQL another bench's opening leaves them alone (that
// bench's import might be in progress).
TEST_P(StoreCrashTest, AWriterKilledMidImportLeavesNothingOfIt) {
  testing::BackgroundProcess writer(SKINSPEC_TEST_BIN_DIR "/store_crash_writer", {target_, "import", "bench-a"});
  ASSERT_TRUE(writer.started()) << writer.start_error();
  ASSERT_TRUE(writer.wait_for_stdout_line("staged ", std::chrono::seconds(60))) << writer.err();
  writer.send_signal(SIGKILL);
  const auto ended = writer.wait(std::chrono::seconds(10));
  ASSERT_EQ(ended.signal, SIGKILL) << ended.describe();
  long long session = 0, job = 0;
  ASSERT_EQ(std::sscanf(ended.out.substr(ended.out.find("staged ")).c_str(), "staged %lld %lld", &session, &job), 2);

  // Four batches of 50 committed (store_crash_writer.cpp), unpublished.
  EXPECT_EQ(raw_count(target_, "measurements"), 200);
  EXPECT_EQ(raw_count(target_, "fits"), 200);
  {
    OpenOptions read_only;
    read_only.mode = OpenMode::read_only;
    read_only.check_integrity = false;
    auto reader = value_of(Store::open(target_, read_only));
    EXPECT_TRUE(value_of(reader.session_detail(session)).measurements.empty());
    EXPECT_TRUE(value_of(reader.session_detail(session)).fits.empty());
    EXPECT_EQ(value_of(reader.job(job)).state, JobState::running);
  }
  OpenOptions options;
  if (GetParam() == Backend::postgresql) {
    options.bench = "bench-b";
    value_of(Store::open(target_, options));
    EXPECT_EQ(raw_count(target_, "measurements"), 200) << "another bench's opening removed bench-a's import";
  }
  options.bench = "bench-a";
  auto store = value_of(Store::open(target_, options));
  EXPECT_THAT(store.recovery().failed_jobs, ::testing::ElementsAre(job));
  EXPECT_EQ(value_of(store.job(job)).error->code, JobErrorCode::interrupted);
  EXPECT_TRUE(value_of(store.session_detail(session)).measurements.empty());
  EXPECT_EQ(raw_count(target_, "measurements"), 0);
  EXPECT_EQ(raw_count(target_, "fits"), 0);
  EXPECT_EQ(raw_count(target_, "imports"), 0);
}

}  // namespace
}  // namespace skinspec
