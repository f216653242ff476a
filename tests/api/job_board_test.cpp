// The board of queued and running jobs on its own: places in each lane's queue, progress and
// the time left, the count of changes and the waits on it, cancelling a queued job against a
// running one, closing a lane, and the jobs an Idempotency-Key names.

#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "skinspec/api/job_board.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::api {
namespace {

using namespace std::chrono_literals;
using store::JobErrorCode;

int position_of(const JobBoard& board, store::Id id) {
  const auto live = board.progress(id);
  EXPECT_TRUE(live) << id;
  return live ? live->position : -1;
}

TEST(JobBoard, QueuedJobsArePlacedInTheOrderOfTheirIdsOneQueueALane) {
  JobBoard board;
  ASSERT_TRUE(board.enqueue(JobLane::instrument, 3));
  ASSERT_TRUE(board.enqueue(JobLane::instrument, 1));  // posted earlier, queued later: before 3
  ASSERT_TRUE(board.enqueue(JobLane::fitting, 2));
  EXPECT_FALSE(board.enqueue(JobLane::instrument, 3)) << "a job is queued once";

  EXPECT_EQ(position_of(board, 1), 1);
  EXPECT_EQ(position_of(board, 3), 2);
  EXPECT_EQ(position_of(board, 2), 1) << "an import does not wait behind measurements";
  EXPECT_EQ(board.load(JobLane::instrument).queued, 2u);
  EXPECT_FALSE(board.progress(4)) << "a job this program does not run";
  EXPECT_TRUE(board.knows(3));
  EXPECT_FALSE(board.knows(4));
}

TEST(JobBoard, ATakenJobIsShownFirstUntilItReportsThenRunning) {
  JobBoard board;
  for (const store::Id id : {1, 2, 3}) ASSERT_TRUE(board.enqueue(JobLane::instrument, id));
  EXPECT_EQ(board.take_next(JobLane::instrument), 1);
  EXPECT_EQ(board.load(JobLane::instrument).running, 1);
  EXPECT_EQ(position_of(board, 1), 1);
  EXPECT_EQ(board.progress(1)->phase, JobPhase::queued);
  EXPECT_EQ(position_of(board, 2), 1);
  EXPECT_EQ(position_of(board, 3), 2);

  EXPECT_FALSE(board.report_phase(1, JobPhase::measuring, 0));
  EXPECT_EQ(position_of(board, 1), 0);
  EXPECT_EQ(board.progress(1)->phase, JobPhase::measuring);
}

TEST(JobBoard, ProgressIsKeptAsReportedAndAPhaseReportKeepsTheRest) {
  JobBoard board;
  ASSERT_TRUE(board.enqueue(JobLane::instrument, 1, JobProgress{1, JobPhase::queued, 0, 5}));
  ASSERT_EQ(board.take_next(JobLane::instrument), 1);
  board.report_phase(1, JobPhase::measuring, 2);
  auto live = board.progress(1);
  ASSERT_TRUE(live);
  EXPECT_EQ(live->readings_done, 2);
  EXPECT_EQ(live->readings_total, 5);

  ASSERT_TRUE(board.enqueue(JobLane::fitting, 2));
  ASSERT_EQ(board.take_next(JobLane::fitting), 2);
  JobProgress fitting{0, JobPhase::fitting};
  fitting.spectra_done = 40;
  fitting.spectra_total = 100;
  fitting.remaining_s = 1.5;
  board.report(2, fitting);
  live = board.progress(2);
  ASSERT_TRUE(live);
  EXPECT_EQ(live->phase, JobPhase::fitting);
  EXPECT_EQ(live->spectra_done, 40);
  EXPECT_EQ(live->spectra_total, 100);
  EXPECT_EQ(live->remaining_s, 1.5);
}

TEST(JobBoard, TheTimeLeftCountsDownUntilAnotherPhaseIsReported) {
  JobBoard board;
  ASSERT_TRUE(board.enqueue(JobLane::instrument, 1, JobProgress{1, JobPhase::queued, 0, 3}));
  ASSERT_EQ(board.take_next(JobLane::instrument), 1);
  board.report_phase(1, JobPhase::measuring, 0);
  board.start_countdown(1, Countdown{std::chrono::steady_clock::now() + 1000ms, 1000ms, 2});
  const auto first = board.progress(1)->remaining_s;
  ASSERT_TRUE(first);
  EXPECT_GT(*first, 2.5);
  EXPECT_LE(*first, 3.0);
  std::this_thread::sleep_for(50ms);
  const auto later = board.progress(1)->remaining_s;
  ASSERT_TRUE(later);
  EXPECT_LT(*later, *first) << "counted down at every look";

  board.report_phase(1, JobPhase::measuring, 1);  // the same phase: still counting
  EXPECT_TRUE(board.progress(1)->remaining_s);
  board.report_phase(1, JobPhase::fitting, 3);
  EXPECT_FALSE(board.progress(1)->remaining_s);
}

TEST(JobBoard, EveryChangeIsCounted) {
  JobBoard board;
  std::uint64_t seen = board.changes();
  const auto grew = [&] {
    const auto now = board.changes();
    const bool more = now > seen;
    seen = now;
    return more;
  };
  board.enqueue(JobLane::fitting, 1);
  EXPECT_TRUE(grew()) << "queued";
  board.enqueue(JobLane::fitting, 2);
  EXPECT_TRUE(grew());
  board.take_next(JobLane::fitting);
  EXPECT_TRUE(grew()) << "taken: the others moved up";
  board.report(1, JobProgress{0, JobPhase::reading});
  EXPECT_TRUE(grew()) << "progress";
  board.withdraw(2);
  EXPECT_TRUE(grew()) << "withdrawn";
  board.end(2);
  EXPECT_TRUE(grew()) << "ended";
  board.note_remote(9, JobProgress{});
  EXPECT_TRUE(grew()) << "another program's job";
  EXPECT_FALSE(grew()) << "nothing changed";
  EXPECT_EQ(board.progress(9)->phase, JobPhase::queued);
}

TEST(JobBoard, AWaitEndsAtTheNextChangeOrWhenItsFollowerIsAbandoned) {
  JobBoard board;
  std::atomic<bool> abandoned{false};
  const auto seen = board.changes();

  // Nothing changes: the wait lasts its timeout.
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(board.wait_for_change(seen, 100ms, abandoned), seen);
  EXPECT_GE(std::chrono::steady_clock::now() - started, 90ms);

  // A change wakes it long before its timeout.
  auto woken = std::async(std::launch::async, [&] { return board.wait_for_change(seen, 30s, abandoned); });
  std::this_thread::sleep_for(50ms);
  board.enqueue(JobLane::instrument, 1);
  ASSERT_EQ(woken.wait_for(10s), std::future_status::ready);
  EXPECT_GT(woken.get(), seen);

  // An abandoned follower is woken without a change.
  const auto now = board.changes();
  auto left = std::async(std::launch::async, [&] { return board.wait_for_change(now, 30s, abandoned); });
  std::this_thread::sleep_for(50ms);
  abandoned = true;
  board.wake_waiters();
  ASSERT_EQ(left.wait_for(10s), std::future_status::ready);
  EXPECT_EQ(left.get(), now);
}

TEST(JobBoard, AWorkerWaitsForTheNextJobOfItsLane) {
  JobBoard board;
  auto taken = std::async(std::launch::async, [&] { return board.take_next(JobLane::instrument); });
  board.enqueue(JobLane::fitting, 1);  // another lane's
  EXPECT_EQ(taken.wait_for(100ms), std::future_status::timeout);
  board.enqueue(JobLane::instrument, 2);
  ASSERT_EQ(taken.wait_for(10s), std::future_status::ready);
  EXPECT_EQ(taken.get(), 2);
}

TEST(JobBoard, AQueuedJobIsWithdrawnWhileARunningOneIsAskedToStop) {
  JobBoard board;
  for (const store::Id id : {1, 2, 3}) board.enqueue(JobLane::instrument, id);
  ASSERT_EQ(board.take_next(JobLane::instrument), 1);

  EXPECT_FALSE(board.ask_to_stop(2, JobErrorCode::cancelled)) << "queued, not running";
  EXPECT_TRUE(board.withdraw(2));
  EXPECT_FALSE(board.withdraw(2)) << "withdrawn once";
  EXPECT_EQ(position_of(board, 3), 1) << "the job behind it moved up";
  board.end(2);
  EXPECT_FALSE(board.progress(2));

  EXPECT_FALSE(board.withdraw(1)) << "running, not queued";
  EXPECT_FALSE(board.stop_asked(1));
  EXPECT_TRUE(board.ask_to_stop(1, JobErrorCode::cancelled));
  EXPECT_EQ(board.stop_asked(1), JobErrorCode::cancelled);
  EXPECT_TRUE(board.ask_to_stop(1, JobErrorCode::stopped));
  EXPECT_EQ(board.stop_asked(1), JobErrorCode::cancelled) << "the first reason stays";
  EXPECT_EQ(board.report_phase(1, JobPhase::measuring, 1), JobErrorCode::cancelled) << "told at its next step";

  board.end(1);
  EXPECT_FALSE(board.progress(1));
  EXPECT_FALSE(board.load(JobLane::instrument).running);
  EXPECT_EQ(board.take_next(JobLane::instrument), 3);
  EXPECT_FALSE(board.stop_asked(3)) << "a new job starts without its predecessor's request";
}

TEST(JobBoard, ClosingALaneStopsItsRunningJobAndHandsBackItsQueue) {
  JobBoard board;
  for (const store::Id id : {1, 2, 3}) board.enqueue(JobLane::instrument, id);
  board.enqueue(JobLane::fitting, 4);
  ASSERT_EQ(board.take_next(JobLane::instrument), 1);
  board.ask_to_stop(1, JobErrorCode::cancelled);

  EXPECT_EQ(board.close(JobLane::instrument), (std::vector<store::Id>{2, 3}));
  EXPECT_EQ(board.stop_asked(1), JobErrorCode::stopped) << "stopping wins over a cancel";
  EXPECT_TRUE(board.closed(JobLane::instrument));
  EXPECT_FALSE(board.enqueue(JobLane::instrument, 5));
  EXPECT_FALSE(board.take_next(JobLane::instrument));
  EXPECT_TRUE(board.progress(2)) << "shown until its record has ended";

  EXPECT_FALSE(board.closed(JobLane::fitting));
  EXPECT_EQ(board.take_next(JobLane::fitting), 4);
}

TEST(JobBoard, AJobWhoseEndWasNotRecordedIsShownFailed) {
  JobBoard board;
  board.track_ends(JobLane::instrument);
  board.enqueue(JobLane::instrument, 1);
  board.enqueue(JobLane::instrument, 2);
  ASSERT_EQ(board.take_next(JobLane::instrument), 1);
  const store::JobError refused{JobErrorCode::store, "the database refused"};
  board.end(1, refused);

  const auto live = board.progress(1);
  ASSERT_TRUE(live);
  EXPECT_EQ(live->phase, JobPhase::done);
  EXPECT_EQ(live->unrecorded_failure, refused);
  EXPECT_TRUE(board.knows(1));
  EXPECT_FALSE(board.load(JobLane::instrument).running) << "its lane is free for the next";

  // Published to the other programs: the live jobs with their places, and what ended.
  auto jobs = board.take_lane_jobs(JobLane::instrument);
  EXPECT_FALSE(jobs.live.contains(1)) << "not published as live";
  ASSERT_TRUE(jobs.live.contains(2));
  EXPECT_EQ(jobs.live[2].position, 1);
  EXPECT_TRUE(jobs.ended.empty());
  board.withdraw(2);
  board.end(2);
  jobs = board.take_lane_jobs(JobLane::instrument);
  EXPECT_TRUE(jobs.live.empty());
  EXPECT_EQ(jobs.ended, (std::vector<store::Id>{2}));
  EXPECT_TRUE(board.take_lane_jobs(JobLane::instrument).ended.empty()) << "handed out once";
}

TEST(JobBoard, AnotherProgramsJobIsShownAsPublishedUntilItEnds) {
  JobBoard board;
  board.note_remote(7, JobProgress{0, JobPhase::measuring, 1, 3});
  EXPECT_EQ(board.remote_jobs(), (std::vector<store::Id>{7}));
  EXPECT_EQ(board.progress(7)->readings_done, 1);
  EXPECT_FALSE(board.knows(7)) << "not run here";
  board.note_remote(7, std::nullopt);
  EXPECT_FALSE(board.progress(7));
  EXPECT_TRUE(board.remote_jobs().empty());
}

TEST(JobBoard, AnIdempotencyKeyNamesItsJobOfTheSameKindOnly) {
  testing::ScratchDirectory dir;
  auto db = store::Store::open(dir.file("jobs.db"));
  ASSERT_TRUE(db) << db.error().message;
  store::Job job;
  job.kind = "import";
  job.idempotency_key = "key-1";
  const auto made = db->create_job(job);
  ASSERT_TRUE(made) << made.error().message;

  const auto none = JobBoard::earlier_job(*db, JobKind::import, "");
  ASSERT_TRUE(none);
  EXPECT_FALSE(*none) << "no key";
  const auto unseen = JobBoard::earlier_job(*db, JobKind::import, "key-2");
  ASSERT_TRUE(unseen);
  EXPECT_FALSE(*unseen);
  const auto seen = JobBoard::earlier_job(*db, JobKind::import, "key-1");
  ASSERT_TRUE(seen);
  ASSERT_TRUE(*seen);
  EXPECT_EQ((*seen)->job.id, made->job.id);
  EXPECT_FALSE((*seen)->created);
  const auto other = JobBoard::earlier_job(*db, JobKind::refit, "key-1");
  ASSERT_FALSE(other);
  EXPECT_EQ(http_status(other.error().kind), 409);
}

TEST(JobBoard, ALaneOfEachKind) {
  EXPECT_EQ(lane_of(JobKind::measure), JobLane::instrument);
  EXPECT_EQ(lane_of(JobKind::import), JobLane::fitting);
  EXPECT_EQ(lane_of(JobKind::refit), JobLane::fitting);
  EXPECT_EQ(stop_error(JobErrorCode::cancelled), (store::JobError{JobErrorCode::cancelled, "cancelled by request"}));
  EXPECT_EQ(stop_error(JobErrorCode::stopped), (store::JobError{JobErrorCode::stopped, "the service stopped"}));
}

}  // namespace
}  // namespace skinspec::api
