// Benches in the store, on both engines: the bench each session and job records, heartbeats,
// the jobs queued for a bench, the recovery of a bench whose program is gone (only once its
// lease ran out and, on PostgreSQL, nobody holds its writer lock), notifications; and on
// PostgreSQL, one writer per bench (docs/store.md, "Benches").

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
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
using namespace std::chrono_literals;
using ::testing::ElementsAre;
using ::testing::IsEmpty;
using testing::sample_session;
using Kind = StoreError::Kind;

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

// A clock that stands still until the test moves it.
struct StillClock {
  std::shared_ptr<Time> now = std::make_shared<Time>(Time(std::chrono::seconds(1'700'000'000)));
  std::function<Time()> function() const {
    return [shared = now] { return *shared; };
  }
  void advance(std::chrono::milliseconds by) const { *now += by; }
};

class StoreBenchesTest : public ::testing::TestWithParam<Backend> {
 protected:
  StoreBenchesTest()
      : target_(GetParam() == Backend::sqlite
                    ? dir_.file("skinspec.db")
                    : testing::postgres_cluster().uri(testing::postgres_cluster().create_database())) {}

  Result<Store> open_as(const std::string& bench) const {
    OpenOptions options;
    options.bench = bench;
    options.clock = clock_.function();
    return Store::open(target_, options);
  }
  Store open(const std::string& bench) const { return value_of(open_as(bench)); }

  static Bench heartbeat(std::chrono::milliseconds lease = 15s) {
    Bench b;
    b.host = "bench-pc";
    b.pid = 4242;
    b.lease = lease;
    b.instrument = R"({"state":"connected"})";
    return b;
  }
  static Job measure_job(Id session, std::string bench = {}) {
    Job job;
    job.kind = "measure";
    job.session_id = session;
    job.bench = std::move(bench);
    return job;
  }
  bool on_postgresql() const { return GetParam() == Backend::postgresql; }

  testing::ScratchDirectory dir_;
  std::string target_;
  StillClock clock_;
};

INSTANTIATE_TEST_SUITE_P(EachBackend, StoreBenchesTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);

TEST_P(StoreBenchesTest, SessionsAndJobsRecordTheirBenchAndEachBenchSeesItsOwnQueue) {
  Store a = open("bench-a");
  EXPECT_EQ(a.bench(), "bench-a");
  const Id session = value_of(a.create_session(sample_session(1)));
  EXPECT_EQ(value_of(a.session(session)).bench, "bench-a");
  const Job own = value_of(a.create_job(measure_job(session))).job;
  const Job other = value_of(a.create_job(measure_job(session, "bench-b"))).job;
  EXPECT_EQ(own.bench, "bench-a");
  EXPECT_EQ(other.bench, "bench-b");
  EXPECT_EQ(value_of(a.job(other.id)).bench, "bench-b");
  const auto queued = value_of(a.queued_jobs());
  ASSERT_EQ(queued.size(), 1u);
  EXPECT_EQ(queued[0].id, own.id);
}

TEST_P(StoreBenchesTest, ASessionFromBeforeBenchesBelongsToTheFirstBenchThatRunsAJobInIt) {
  Id session = 0;
  {
    Store a = open("bench-a");
    session = value_of(a.create_session(sample_session(1)));
  }
  testing::raw_database(target_)->execute("UPDATE sessions SET bench = ''");
  Store b = open("bench-b");
  EXPECT_EQ(value_of(b.session(session)).bench, "");
  value_of(b.create_job(measure_job(session)));
  EXPECT_EQ(value_of(b.session(session)).bench, "bench-b");
}

TEST_P(StoreBenchesTest, AHeartbeatListsTheBenchRunningUntilItLeavesOrItsLeaseRunsOut) {
  Store a = open("bench-a");
  EXPECT_THAT(value_of(a.benches()), IsEmpty());
  ASSERT_TRUE(a.beat(heartbeat(15s)));
  auto listed = value_of(a.benches());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].name, "bench-a");
  EXPECT_EQ(listed[0].host, "bench-pc");
  EXPECT_EQ(listed[0].pid, 4242);
  EXPECT_EQ(listed[0].lease, 15s);
  EXPECT_EQ(listed[0].heartbeat_at, *clock_.now);
  EXPECT_THAT(listed[0].instrument, ::testing::HasSubstr("connected"));
  EXPECT_TRUE(bench_running(listed[0], *clock_.now + 15s));
  EXPECT_FALSE(bench_running(listed[0], *clock_.now + 15s + 1ms));

  ASSERT_TRUE(a.leave_bench());
  listed = value_of(a.benches());
  ASSERT_TRUE(listed[0].stopped_at.has_value());
  EXPECT_FALSE(bench_running(listed[0], *clock_.now));
  ASSERT_TRUE(a.beat(heartbeat()));
  EXPECT_TRUE(bench_running(value_of(a.benches())[0], *clock_.now));

  auto bad = heartbeat();
  bad.instrument = "[1]";
  EXPECT_EQ(a.beat(bad).error().kind, Kind::invalid_argument);
}

TEST_P(StoreBenchesTest, AQueuedJobCancelledElsewhereCannotStartAndARunningOneCannotBeCancelledAsQueued) {
  Store a = open("bench-a");
  const Id session = value_of(a.create_session(sample_session(1)));
  const Id first = value_of(a.create_job(measure_job(session))).job.id;
  const Id second = value_of(a.create_job(measure_job(session))).job.id;
  const JobError cancelled{JobErrorCode::cancelled, "cancelled"};
  ASSERT_TRUE(a.update_job(first, {JobState::cancelled, cancelled, std::nullopt, JobState::queued}));
  EXPECT_EQ(a.update_job(first, {JobState::running, std::nullopt, std::nullopt, JobState::queued}).error().kind,
            Kind::conflict);
  ASSERT_TRUE(a.update_job(second, {JobState::running, std::nullopt, std::nullopt, JobState::queued}));
  EXPECT_EQ(a.update_job(second, {JobState::cancelled, cancelled, std::nullopt, JobState::queued}).error().kind,
            Kind::conflict);
  EXPECT_EQ(value_of(a.job(second)).state, JobState::running);
}

TEST_P(StoreBenchesTest, ANotificationReachesEverySubscriberOfItsChannelOnly) {
  Store a = open("bench-a");
  auto jobs = value_of(a.subscribe({"skinspec_jobs"}));
  auto both = value_of(a.subscribe({"skinspec_jobs", "skinspec_job_events"}));
  ASSERT_TRUE(a.notify("skinspec_job_events", R"({"job":1})"));
  ASSERT_TRUE(a.notify("skinspec_jobs", "bench-a"));
  std::vector<Notification> got;
  for (int i = 0; i < 20 && got.size() < 2; ++i)
    for (auto& n : value_of(both->wait(100ms))) got.push_back(n);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].channel, "skinspec_job_events");
  EXPECT_EQ(got[0].payload, R"({"job":1})");
  EXPECT_EQ(got[1].channel, "skinspec_jobs");
  EXPECT_EQ(got[1].payload, "bench-a");
  const auto only_jobs = value_of(jobs->wait(1000ms));
  ASSERT_EQ(only_jobs.size(), 1u);
  EXPECT_EQ(only_jobs[0].payload, "bench-a");
  EXPECT_THAT(value_of(jobs->wait(50ms)), IsEmpty());
}

class PostgresqlBenchesTest : public StoreBenchesTest {};
INSTANTIATE_TEST_SUITE_P(Postgresql, PostgresqlBenchesTest, ::testing::Values(Backend::postgresql),
                         testing::backend_name);
class SqliteBenchesTest : public StoreBenchesTest {};
INSTANTIATE_TEST_SUITE_P(Sqlite, SqliteBenchesTest, ::testing::Values(Backend::sqlite), testing::backend_name);

// One program writes a SQLite file, whatever its bench: whoever opens it next recovers every
// job left running, the host's name having changed or not.
TEST_P(SqliteBenchesTest, OpeningAFileRecoversTheJobsOfEveryBench) {
  Id job = 0;
  {
    Store b = open("bench-b");
    job = value_of(b.create_job(measure_job(value_of(b.create_session(sample_session(1)))))).job.id;
  }
  Store a = open("bench-a");
  EXPECT_THAT(a.recovery().failed_jobs, ElementsAre(job));
  EXPECT_EQ(value_of(a.job(job)).error->code, JobErrorCode::interrupted);
}

// Bench B's program wrote its heartbeat, opened a session and started a job, then went silent.
TEST_P(PostgresqlBenchesTest, ASilentBenchsJobsAreInterruptedOnlyOnceItsLeaseRanOut) {
  Id b_session = 0, b_running = 0, b_queued = 0, a_job = 0;
  {
    Store b = open("bench-b");
    ASSERT_TRUE(b.beat(heartbeat(10s)));
    b_session = value_of(b.create_session(sample_session(1)));
    b_running = value_of(b.create_job(measure_job(b_session))).job.id;
    ASSERT_TRUE(b.update_job(b_running, {JobState::running}));
    b_queued = value_of(b.create_job(measure_job(b_session))).job.id;
  }
  Store a = open("bench-a");
  EXPECT_THAT(a.recovery().failed_jobs, IsEmpty()) << "another bench's jobs are not this opener's";
  const Id a_session = value_of(a.create_session(sample_session(2)));
  a_job = value_of(a.create_job(measure_job(a_session))).job.id;

  clock_.advance(10s);
  EXPECT_THAT(value_of(a.recover_bench("bench-b")).failed_jobs, IsEmpty()) << "within its lease";
  EXPECT_EQ(value_of(a.job(b_running)).state, JobState::running);

  clock_.advance(1ms);
  // Its lock goes with its closed connection, which the server ends a moment after the close.
  RecoveryReport report;
  for (int attempt = 0; attempt < 100 && report.failed_jobs.empty(); ++attempt) {
    report = value_of(a.recover_bench("bench-b"));
    if (report.failed_jobs.empty()) std::this_thread::sleep_for(20ms);
  }
  EXPECT_THAT(report.failed_jobs, ElementsAre(b_running, b_queued));
  EXPECT_THAT(report.interrupted_sessions, ElementsAre(b_session));
  for (const Id id : {b_running, b_queued}) {
    const Job job = value_of(a.job(id));
    EXPECT_EQ(job.state, JobState::failed);
    ASSERT_TRUE(job.error.has_value());
    EXPECT_EQ(job.error->code, JobErrorCode::interrupted);
  }
  EXPECT_EQ(value_of(a.session(b_session)).state, SessionState::interrupted);
  EXPECT_EQ(value_of(a.job(a_job)).state, JobState::queued) << "only bench B's jobs";
  EXPECT_THAT(value_of(a.recover_bench("bench-b")).failed_jobs, IsEmpty()) << "nothing left to recover";
  EXPECT_THAT(value_of(a.recover_bench("bench-a")).failed_jobs, IsEmpty()) << "never its own";
  EXPECT_THAT(value_of(a.recover_bench("bench-nobody")).failed_jobs, IsEmpty());
}

TEST_P(PostgresqlBenchesTest, EachBenchHasItsOwnWriterAndASecondProgramForOneBenchIsBusy) {
  Store a = open("bench-a");
  Store b = open("bench-b");
  EXPECT_GT(value_of(a.create_session(sample_session(1))), 0);
  EXPECT_GT(value_of(b.create_session(sample_session(2))), 0);
  const auto again = open_as("bench-a");
  ASSERT_FALSE(again.has_value());
  EXPECT_EQ(again.error().kind, Kind::busy);
  EXPECT_THAT(again.error().message, ::testing::HasSubstr("bench bench-a"));
}

// skinspec before benches held the one-key writer lock alone: while such a program writes the
// database, a newer one is refused (it would migrate the schema under it), and lets go after.
TEST_P(PostgresqlBenchesTest, AnOlderWriterFromBeforeBenchesKeepsNewerOnesOut) {
  open("bench-a");  // the schema made, and let go
  {
    auto older = testing::raw_database(target_);
    // The closed writer's backend lets go of its share a moment after the close.
    bool taken = false;
    for (int attempt = 0; attempt < 100 && !taken; ++attempt) {
      taken = older->text("SELECT pg_try_advisory_lock(1397445457)::text") == "true";
      if (!taken) std::this_thread::sleep_for(20ms);
    }
    ASSERT_TRUE(taken);
    const auto refused = open_as("bench-a");
    ASSERT_FALSE(refused.has_value());
    EXPECT_EQ(refused.error().kind, Kind::busy);
    EXPECT_THAT(refused.error().message, ::testing::HasSubstr("older skinspecd"));
  }
  Store a = open("bench-a");
  Store b = open("bench-b");  // benches share it
  auto older = testing::raw_database(target_);
  EXPECT_EQ(older->text("SELECT pg_try_advisory_lock(1397445457)::text"), "false");
}

TEST_P(PostgresqlBenchesTest, OpeningRecoversOnlyItsOwnBenchsJobs) {
  Store a = open("bench-a");
  const Id a_job = value_of(a.create_job(measure_job(value_of(a.create_session(sample_session(1)))))).job.id;
  Id b_job = 0;
  {
    Store b = open("bench-b");
    b_job = value_of(b.create_job(measure_job(value_of(b.create_session(sample_session(2)))))).job.id;
  }
  Store b = open("bench-b");
  EXPECT_THAT(b.recovery().failed_jobs, ElementsAre(b_job));
  EXPECT_EQ(value_of(a.job(a_job)).state, JobState::queued);
}

// Bench A's program is importing a file, two batches of it committed and unpublished, when bench
// B's program opens the database: an opening removes the unpublished imports of its own bench
// only (those its program left when it died), and A's import is published whole.
TEST_P(PostgresqlBenchesTest, OpeningLeavesAnotherBenchsImportInProgressAlone) {
  OpenOptions options;
  options.bench = "bench-a";
  options.clock = clock_.function();
  options.import_batch = 50;
  Store a = value_of(Store::open(target_, options));
  const Id session = value_of(a.create_session(sample_session(1)));
  std::vector<std::pair<Measurement, std::optional<Fit>>> rows;
  for (int i = 0; i < 200; ++i) rows.emplace_back(testing::sample_measurement(session, i), testing::sample_fit(i));
  std::optional<Store> b;
  std::size_t given = 0;
  const auto stored = a.record_measurements_as_ready([&]() -> const std::pair<Measurement, std::optional<Fit>>* {
    if (given == 120) b.emplace(open("bench-b"));
    return given < rows.size() ? &rows[given++] : nullptr;
  });
  ASSERT_TRUE(stored) << stored.error().message;
  EXPECT_EQ(stored->size(), 200u);
  ASSERT_TRUE(b);
  EXPECT_EQ(value_of(b->session_detail(session)).measurements.size(), 200u);
  EXPECT_EQ(value_of(b->session_detail(session)).fits.size(), 200u);
}

TEST_P(PostgresqlBenchesTest, ABenchWhoseProgramStillHoldsItsLockIsNotRecoveredWhateverItsHeartbeat) {
  Store b = open("bench-b");
  ASSERT_TRUE(b.beat(heartbeat(2s)));
  const Id job = value_of(b.create_job(measure_job(value_of(b.create_session(sample_session(1)))))).job.id;
  Store a = open("bench-a");
  clock_.advance(1h);
  EXPECT_THAT(value_of(a.recover_bench("bench-b")).failed_jobs, IsEmpty());
  EXPECT_EQ(value_of(a.job(job)).state, JobState::queued);
}

TEST_P(PostgresqlBenchesTest, ANotificationFromAnotherProgramArrives) {
  Store a = open("bench-a");
  Store b = open("bench-b");
  auto listening = value_of(a.subscribe({"skinspec_jobs"}));
  ASSERT_TRUE(b.notify("skinspec_jobs", "bench-a"));
  std::vector<Notification> got;
  for (int i = 0; i < 50 && got.empty(); ++i) got = value_of(listening->wait(100ms));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].payload, "bench-a");
}

}  // namespace
}  // namespace skinspec
