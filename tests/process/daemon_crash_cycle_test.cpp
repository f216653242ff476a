// skinspecd SIGKILLed at seeded random moments while it runs measurement jobs against
// skinspec-sim (time scale 0), then started again on the same database, 102 times over. After
// each kill the file is intact and its jobs agree with its rows (every stored measurement's job
// has succeeded and names it, every succeeded job has its measurement and fit); after each
// restart every job of the cycle has either succeeded, with its measurement and fit readable
// through the API, or failed with the code `interrupted`. scripts/soak runs it for 1,000 kills
// (SKINSPEC_SOAK_KILLS), from other seeds (SKINSPEC_SOAK_SEED).

#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string_view>
#include <thread>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "support/soak_size.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

struct Tally {
  int killed_while_running = 0;  // a job had started and not ended when the daemon died
  int killed_while_queued = 0;   // jobs waited, none ran
  int succeeded = 0, interrupted = 0;
  int killed_after_a_job_ended = 0;  // cycles whose kill followed the end of their first job
};

// The jobs of one cycle after the restart: each ended, and as the kill left it.
void expect_ended_as_the_kill_left_them(unsigned short port, const std::vector<long long>& jobs, Tally& tally) {
  for (const long long id : jobs) {
    const json job = get_json(port, "/api/v1/jobs/" + std::to_string(id));
    const std::string state = job.value("state", "");
    if (state == "succeeded") {
      ++tally.succeeded;
      EXPECT_TRUE(job["error"].is_null()) << job;
      const auto& result = job["result"];
      ASSERT_TRUE(result["measurement_id"].is_number_integer()) << job;
      ASSERT_TRUE(result["fit_id"].is_number_integer()) << job;
      const auto m = http_request(port, "GET",
                                  "/api/v1/measurements/" + std::to_string(result["measurement_id"].get<long long>()));
      ASSERT_EQ(m.status, 200) << job;
      EXPECT_EQ(m.json()["provenance"]["job_id"], id) << job;
      EXPECT_EQ(http_request(port, "GET", "/api/v1/fits/" + std::to_string(result["fit_id"].get<long long>())).status,
                200)
          << job;
    } else {
      ++tally.interrupted;
      EXPECT_EQ(state, "failed") << job;
      EXPECT_EQ(job["error"]["code"], "interrupted") << job;
      EXPECT_TRUE(job["position"].is_null()) << job;
    }
  }
}

// Whether the restarted daemon has the meter again, so that the next kills land among jobs
// rather than in its reconnection.
bool meter_connected(unsigned short port) {
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < until) {
    if (get_json(port, "/api/v1/instrument").value("state", "") == "connected") return true;
    std::this_thread::sleep_for(2ms);
  }
  return false;
}

// Until the job's state is none of `states` (it may have gone past the next), or 30 s have passed.
void wait_while(unsigned short port, long long job, std::initializer_list<std::string_view> states) {
  const auto until = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < until) {
    const std::string state = get_json(port, "/api/v1/jobs/" + std::to_string(job)).value("state", "");
    if (std::ranges::find(states, state) == states.end()) return;
    std::this_thread::sleep_for(200us);
  }
}

// Where a cycle's kill lands. A random delay alone would not do on every build: under the
// sanitizers a job takes longer than the longest delay, and on a loaded machine jobs start late.
enum class Aim { anywhere, a_job_at_work, after_the_first_job };

// One rig's cycles: jobs submitted, the daemon killed after a seeded random delay, checked,
// started again.
void run_cycles(const std::string& work_dir, unsigned seed, int cycles, Tally& tally) {
  // A quick first reconnection: the meter may still be busy with the killed daemon's link.
  AcquisitionRig rig(rig_options(work_dir, {"--quiet"}, {"--log-level", "warn", "--reconnect-initial-ms", "20"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "C1");
  ASSERT_EQ(wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}))["state"], "succeeded") << rig.logs();
  const std::string session_path = "/api/v1/sessions/" + std::to_string(session);

  std::mt19937 random(seed);
  std::uniform_int_distribution<int> jobs_per_cycle(1, 4);
  // A sample job takes a few milliseconds here: kills land before, inside and after jobs.
  std::uniform_int_distribution<int> delay_us(0, 30'000);
  std::uniform_int_distribution<int> aim(0, 2);  // an Aim
  for (int cycle = 0; cycle < cycles; ++cycle) {
    SCOPED_TRACE("seed " + std::to_string(seed) + ", cycle " + std::to_string(cycle));
    ASSERT_TRUE(meter_connected(rig.port)) << rig.logs();
    std::vector<long long> jobs;
    for (int n = jobs_per_cycle(random); n > 0; --n) {
      const json accepted = submit(rig.port, session, {{"kind", "sample"}});
      ASSERT_TRUE(accepted.contains("job_id")) << accepted << rig.logs();
      jobs.push_back(accepted["job_id"].get<long long>());
    }
    const auto aimed = static_cast<Aim>(aim(random));
    switch (aimed) {
      case Aim::a_job_at_work:
        // Seen running, the job is already a poll's round trip in; of the few milliseconds it
        // takes, at most 0.3 ms more are left to chance.
        wait_while(rig.port, jobs.front(), {"queued"});
        std::this_thread::sleep_for(std::chrono::microseconds(delay_us(random) / 100));
        break;
      case Aim::after_the_first_job:
        wait_while(rig.port, jobs.front(), {"queued", "running"});
        ++tally.killed_after_a_job_ended;
        std::this_thread::sleep_for(std::chrono::microseconds(delay_us(random) / 10));
        break;
      case Aim::anywhere:
        std::this_thread::sleep_for(std::chrono::microseconds(delay_us(random)));
        break;
    }
    rig.daemon->send_signal(SIGKILL);
    ASSERT_EQ(rig.daemon->wait(10s).signal, SIGKILL);

    ASSERT_EQ(sqlite_text(rig.db_path(), "PRAGMA integrity_check"), "ok");
    EXPECT_EQ(jobs_and_rows_disagreement(rig.db_path()), "");
    const auto running = sqlite_integer(rig.db_path(), "SELECT count(*) FROM jobs WHERE state = 'running'");
    const auto queued = sqlite_integer(rig.db_path(), "SELECT count(*) FROM jobs WHERE state = 'queued'");
    EXPECT_LE(running, 1);
    tally.killed_while_running += running > 0;
    tally.killed_while_queued += running == 0 && queued > 0;

    rig.restart_daemon();
    ASSERT_TRUE(rig.ready()) << rig.logs();
    EXPECT_EQ(jobs_and_rows_disagreement(rig.db_path()), "");
    EXPECT_EQ(sqlite_integer(rig.db_path(), "SELECT count(*) FROM jobs WHERE state IN ('queued', 'running')"), 0);
    expect_ended_as_the_kill_left_them(rig.port, jobs, tally);
    if (aimed == Aim::after_the_first_job) {
      EXPECT_EQ(get_json(rig.port, "/api/v1/jobs/" + std::to_string(jobs.front()))["state"], "succeeded");
    }
    if (::testing::Test::HasFatalFailure()) return;
    // Recovery interrupts a session whose jobs were cut short; the operator carries on with it.
    if (get_json(rig.port, session_path)["state"] == "interrupted") {
      ASSERT_EQ(http_request(rig.port, "PATCH", session_path, R"({"state": "open"})").status, 200);
    }
  }
}

TEST(DaemonCrashCycleTest, KilledAtRandomMomentsItsJobsAndRowsAlwaysAgree) {
  // Three rigs at once, each on its own database: a restarted daemon spends most of its time
  // waiting for the meter to settle, not computing.
  constexpr int kRigs = 3;
  const int cycles_per_rig = (soak_size("SKINSPEC_SOAK_KILLS", 102) + kRigs - 1) / kRigs;
  const auto first_seed = static_cast<unsigned>(soak_size("SKINSPEC_SOAK_SEED", 1312));
  ScratchDirectory dir;
  std::vector<Tally> tallies(kRigs);
  const auto started = std::chrono::steady_clock::now();
  {
    std::vector<std::jthread> rigs;
    for (int r = 0; r < kRigs; ++r) {
      const auto work_dir = dir.path() / ("rig" + std::to_string(r));
      std::filesystem::create_directories(work_dir);
      auto& tally = tallies[static_cast<std::size_t>(r)];
      rigs.emplace_back([&tally, r, work_dir, first_seed, cycles_per_rig] {
        run_cycles(work_dir.string(), first_seed + static_cast<unsigned>(r), cycles_per_rig, tally);
      });
    }
  }
  Tally total;
  for (const auto& t : tallies) {
    total.killed_while_running += t.killed_while_running;
    total.killed_while_queued += t.killed_while_queued;
    total.succeeded += t.succeeded;
    total.interrupted += t.interrupted;
    total.killed_after_a_job_ended += t.killed_after_a_job_ended;
  }
  const auto seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::printf("%d kills in %.1f s: %d while a job ran, %d while jobs only waited; %d jobs succeeded, %d interrupted\n",
              kRigs * cycles_per_rig, seconds, total.killed_while_running, total.killed_while_queued, total.succeeded,
              total.interrupted);
  // The kills must have hit jobs at work, and jobs must have finished between them.
  EXPECT_GE(total.killed_while_running, kRigs * cycles_per_rig / 4);
  EXPECT_GE(total.killed_after_a_job_ended, kRigs * cycles_per_rig / 6);
}

}  // namespace
}  // namespace skinspec::testing
