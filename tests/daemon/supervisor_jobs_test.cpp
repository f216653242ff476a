// The supervisor's jobs in-process, against skinspec-sim: when the database refuses a job's
// end, the job is shown failed with a store error at once (never left running), nothing of it
// is stored, and the next start of the database fails its record as interrupted; a refusal
// that passes is asked again; cancelled and stopped jobs end by their codes.

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <thread>

#include "fitter_loader.hpp"
#include "supervisor.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "support/service_processes.hpp"

namespace skinspec::daemon {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

// Another connection holding the database's write lock (BEGIN IMMEDIATE) until released or
// destroyed: every write of the store waits for it, then fails as busy.
class WriteLock {
 public:
  explicit WriteLock(const std::string& path) {
    EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db_);
  }
  ~WriteLock() { release(); }
  WriteLock(const WriteLock&) = delete;
  WriteLock& operator=(const WriteLock&) = delete;
  void release() {
    if (db_ == nullptr) return;
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    sqlite3_close(db_);
    db_ = nullptr;
  }

 private:
  sqlite3* db_ = nullptr;
};

// Polls `done` for up to 30 s.
bool eventually(const std::function<bool()>& done) {
  for (auto until = std::chrono::steady_clock::now() + 30s; std::chrono::steady_clock::now() < until;) {
    if (done()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return false;
}

class SupervisorJobsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // About 0.35 s a reading: long enough to take the database away while a job measures.
    sim_ = testing::start_simulator(dir_, "127.0.0.1:0", {}, "0.05");
    ASSERT_NE(sim_.port, 0) << sim_.process->err();
    auto fitter = load_fitter(SKINSPEC_TEST_DATA_DIR);
    ASSERT_TRUE(fitter) << fitter.error();
    fitter_.emplace(std::move(*fitter));
    store::OpenOptions options;
    options.busy_timeout = 50ms;
    auto db = store::Store::open(path_, options);
    ASSERT_TRUE(db) << db.error().message;
    db_.emplace(std::move(*db));
    supervisor_ = std::make_unique<Supervisor>("tcp:127.0.0.1:" + std::to_string(sim_.port), *db_, *fitter_);
    supervisor_->start();
    const auto session = db_->create_session(testing::sample_session(1));
    ASSERT_TRUE(session) << session.error().message;
    session_ = *session;
  }

  store::Id submit(store::MeasurementKind kind) {
    api::MeasureRequest request;
    request.kind = kind;
    auto created = supervisor_->submit(session_, request, "");
    EXPECT_TRUE(created) << created.error().message;
    return created ? created->job.id : 0;
  }
  // The job as GET /api/v1/jobs/{id} shows it.
  json shown(store::Id id) const {
    auto view = api::current_job_json(*db_, &supervisor_->jobs(), id);
    EXPECT_TRUE(view) << view.error().message;
    return view ? *view : json();
  }
  bool ended(store::Id id) const {
    const auto state = shown(id).value("state", "");
    return state != "queued" && state != "running";
  }

  testing::ScratchDirectory dir_;
  std::string path_ = dir_.file("lab.db");
  testing::ListeningProcess sim_;
  std::optional<Fitter> fitter_;
  std::optional<store::Store> db_;
  std::unique_ptr<Supervisor> supervisor_;
  store::Id session_ = 0;
};

TEST_F(SupervisorJobsTest, AJobWhoseEndTheDatabaseRefusesShowsFailedAtOnceAndStoresNothing) {
  const auto white = submit(store::MeasurementKind::white);
  ASSERT_TRUE(eventually([&] { return ended(white); }));
  ASSERT_EQ(shown(white)["state"], "succeeded") << shown(white) << sim_.process->err();

  const auto sample = submit(store::MeasurementKind::sample);
  ASSERT_TRUE(eventually([&] {
    const auto live = supervisor_->jobs().progress(sample);
    return live && live->phase == api::JobPhase::measuring;
  }));
  WriteLock lock(path_);
  // The measurement with the job's end, then the job's failure: each refused three times.
  ASSERT_TRUE(eventually([&] { return ended(sample); }));
  const json job = shown(sample);
  EXPECT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "store") << job;
  EXPECT_NE(job["error"]["message"].get<std::string>().find("the measurement could not be stored"), std::string::npos)
      << job;
  EXPECT_TRUE(job["position"].is_null()) << job;
  lock.release();

  // The record still says running; nothing of the job was stored.
  EXPECT_EQ(db_->job(sample)->state, store::JobState::running);
  EXPECT_EQ(testing::sqlite_integer(path_, "SELECT count(*) FROM measurements"), 1);  // the white
  EXPECT_EQ(testing::jobs_and_rows_disagreement(path_), "");

  // The database is back: the next job succeeds.
  const auto next = submit(store::MeasurementKind::sample);
  ASSERT_TRUE(eventually([&] { return ended(next); }));
  EXPECT_EQ(shown(next)["state"], "succeeded") << shown(next);

  // The next start of the database fails the record left running, as interrupted.
  supervisor_->stop();
  supervisor_.reset();
  db_.reset();
  auto reopened = store::Store::open(path_);
  ASSERT_TRUE(reopened) << reopened.error().message;
  const auto after = reopened->job(sample);
  ASSERT_TRUE(after);
  EXPECT_EQ(after->state, store::JobState::failed);
  ASSERT_TRUE(after->error);
  EXPECT_EQ(after->error->code, store::JobErrorCode::interrupted);
  EXPECT_EQ(testing::jobs_and_rows_disagreement(path_), "");
}

TEST_F(SupervisorJobsTest, AWriteRefusedForAMomentIsAskedAgainAndTheJobSucceeds) {
  const auto white = submit(store::MeasurementKind::white);
  ASSERT_TRUE(eventually([&] { return ended(white); }));
  const auto sample = submit(store::MeasurementKind::sample);
  const auto in_phase = [&](api::JobPhase phase) {
    return eventually([&] {
      const auto live = supervisor_->jobs().progress(sample);
      return live && live->phase == phase;
    });
  };
  ASSERT_TRUE(in_phase(api::JobPhase::measuring));
  WriteLock lock(path_);
  ASSERT_TRUE(in_phase(api::JobPhase::storing));
  // Refused once or twice; the third attempt comes 300 ms and three busy waits later.
  std::this_thread::sleep_for(100ms);
  lock.release();
  ASSERT_TRUE(eventually([&] { return ended(sample); }));
  const json job = shown(sample);
  EXPECT_EQ(job["state"], "succeeded") << job;
  EXPECT_EQ(db_->job(sample)->state, store::JobState::succeeded);
  EXPECT_EQ(testing::jobs_and_rows_disagreement(path_), "");
}

TEST_F(SupervisorJobsTest, CancellingARunningJobEndsItCancelledByItsCode) {
  const auto white = submit(store::MeasurementKind::white);
  ASSERT_TRUE(eventually([&] {
    const auto live = supervisor_->jobs().progress(white);
    return live && live->phase == api::JobPhase::measuring;
  }));
  ASSERT_TRUE(supervisor_->cancel(white));
  ASSERT_TRUE(eventually([&] { return ended(white); }));
  const auto job = db_->job(white);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->state, store::JobState::cancelled);
  EXPECT_EQ(job->error, (store::JobError{store::JobErrorCode::cancelled, "cancelled by request"}));

  // The running job and the queued one end cancelled with the code `stopped` when the service
  // stops.
  const auto first = submit(store::MeasurementKind::white);
  const auto second = submit(store::MeasurementKind::white);
  ASSERT_TRUE(eventually([&] {
    const auto live = supervisor_->jobs().progress(first);
    return live && live->phase == api::JobPhase::measuring;
  }));
  EXPECT_EQ(shown(second)["position"], 1);
  supervisor_->stop();
  for (const auto id : {first, second}) {
    const auto stopped = db_->job(id);
    ASSERT_TRUE(stopped);
    EXPECT_EQ(stopped->state, store::JobState::cancelled) << id;
    ASSERT_TRUE(stopped->error) << id;
    EXPECT_EQ(stopped->error->code, store::JobErrorCode::stopped) << id;
  }
}

}  // namespace
}  // namespace skinspec::daemon
