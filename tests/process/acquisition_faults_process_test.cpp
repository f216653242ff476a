// Acquisition under every fault the simulator can play, with real processes on loopback: the
// job ends as it must (failed with the right error, or succeeded where the driver or the job's
// retry legitimately recovers), nothing is half-stored, the service keeps serving, and the next
// job succeeds once the fault is over. Then the daemon killed in the middle of a session, twenty
// clients at once, and the warnings for an old white and a changed lamp.

#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <functional>
#include <ranges>
#include <thread>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "support/job_error.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

// Stored samples without their fit: there must never be any.
long long samples_without_fit(const std::string& db) {
  return sqlite_integer(db,
                        "SELECT count(*) FROM measurements m WHERE kind = 'sample' AND NOT EXISTS "
                        "(SELECT 1 FROM fits f WHERE f.measurement_id = m.id)");
}

bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds limit = 10s) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

struct FaultCase {
  std::string name;
  std::vector<std::string> specs;  // each hits the session's first sample: white first, so @2
  bool succeeds;                   // the job's end: succeeded, or failed with `error`
  std::string error;               // the start of the job's error ("code: message") when it fails
  std::size_t rejected = 0;        // readings rejected (and stored) on the way
  bool power_cycle = false;        // the fault lasts until the meter is power-cycled (SIGHUP)
  std::string warning = {};        // the start of a warning the job's result must carry
  // The sample's integration time: a fixed one bounds the wait for a silent M0 to 2 x 600 ms
  // plus the overhead, where adaptive integration is allowed 30 s.
  int integration_ms = 0;
};

void PrintTo(const FaultCase& c, std::ostream* os) { *os << c.name; }

class FaultTest : public ::testing::TestWithParam<FaultCase> {
 protected:
  ScratchDirectory dir_;
};

TEST_P(FaultTest, TheJobEndsAsItMustAndTheNextOneSucceeds) {
  const auto& c = GetParam();
  std::vector<std::string> sim_args;
  for (const auto& spec : c.specs) sim_args.insert(sim_args.end(), {"--fault", spec});
  AcquisitionRig rig(rig_options(dir_.path().string(), sim_args));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "F1");
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();

  const auto job = wait_for_job(p, submit(p, session, {{"kind", "sample"}, {"integration_ms", c.integration_ms}}));
  const auto detail = get_json(p, session_path(session));
  if (c.succeeds) {
    ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
    EXPECT_EQ(detail["measurements"].size(), 2u) << detail;
    EXPECT_FALSE(job["result"]["fit_id"].is_null()) << job;
  } else {
    ASSERT_EQ(job["state"], "failed") << job << rig.logs();
    EXPECT_TRUE(job_error_text(job).starts_with(c.error)) << job["error"];
    EXPECT_EQ(detail["measurements"].size(), 1u) << detail;  // only the white
    EXPECT_EQ(sqlite_integer(rig.db_path(), "SELECT count(*) FROM fits"), 0);
  }
  EXPECT_EQ(job["result"]["rejected_reading_ids"].size(), c.rejected) << job;
  if (!c.warning.empty()) {
    const auto& warnings = job["result"]["warnings"];
    EXPECT_TRUE(std::ranges::any_of(warnings, [&](const json& w) {
      return w.get<std::string>().starts_with(c.warning);
    })) << job;
  }
  EXPECT_EQ(detail["rejected_readings"].size(), c.rejected) << detail;
  EXPECT_EQ(samples_without_fit(rig.db_path()), 0);
  EXPECT_EQ(http_request(p, "GET", "/healthz").status, 200);

  // The fault is over once the meter has finished with the connection the daemon gave up on
  // (a late reply is still being sent), or has been power-cycled after a reboot.
  if (!c.succeeds && !c.error.starts_with("bad_reading")) {
    EXPECT_TRUE(eventually([&] {
      return rig.sim->err().find(": closed") != std::string::npos ||
             rig.sim->err().find(": disconnected") != std::string::npos;
    })) << rig.logs();
  }
  if (c.power_cycle) rig.sim->send_signal(SIGHUP);
  const auto next = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  EXPECT_EQ(next["state"], "succeeded") << next << rig.logs();
  EXPECT_EQ(next["result"]["rejected_reading_ids"].size(), 0u) << next;
  EXPECT_EQ(samples_without_fit(rig.db_path()), 0);
}

// The sample's commands after the white's: S, M0, D5, D1, D2 are each the second of their kind.
INSTANTIATE_TEST_SUITE_P(
    EverySimulatorFault, FaultTest,
    ::testing::Values(
        // One lost reply to any command is asked for again (setup and reports) or measured
        // again with a warning (M0); two in a row lose the meter.
        FaultCase{"no_answer_s", {"s:no-answer@2"}, true, ""},
        FaultCase{"no_answer_m0", {"m0:no-answer@2"}, true, "", 0, false, "remeasured:", 600},
        FaultCase{"no_answer_d5", {"d5:no-answer@2"}, true, ""},
        FaultCase{"no_answer_d1", {"d1:no-answer@2"}, true, ""},
        FaultCase{"no_answer_d2", {"d2:no-answer@2"}, true, ""},
        FaultCase{"no_answer_twice", {"d1:no-answer@2", "d1:no-answer@3"}, false, "lost"},
        FaultCase{"late_within_the_deadline", {"d5:late=300@2"}, true, ""},
        FaultCase{"late_within_the_second_request", {"d1:late=800@2"}, true, ""},
        FaultCase{"late_past_the_deadline", {"d1:late=4000@2"}, false, "lost"},
        // One garbled or cut reply is asked for again (the meter keeps its last measurement);
        // a cut one after the reply's pause deadline. A damaged M0 status is not measured again.
        FaultCase{"garbage_s", {"s:garbage@2"}, true, ""}, FaultCase{"garbage_m0", {"m0:garbage@2"}, true, ""},
        FaultCase{"garbage_d1", {"d1:garbage@2"}, true, ""}, FaultCase{"truncate_d2", {"d2:truncate@2"}, true, ""},
        FaultCase{"truncate", {"d5:truncate@2"}, true, ""}, FaultCase{"garbage", {"d5:garbage@2"}, true, ""},
        FaultCase{"bitflip", {"d5:bitflip=8@2"}, true, ""}, FaultCase{"drop_line", {"d5:drop-line@2"}, true, ""},
        FaultCase{"line_count", {"d5:line-count=90@2"}, true, ""},
        FaultCase{"garbage_twice", {"d5:garbage@2", "d5:garbage@3"}, false, "protocol"},
        FaultCase{"disconnect", {"d5:disconnect@2"}, false, "lost"},
        // A bad quality code: stored apart, measured again.
        FaultCase{"quality", {"m0:quality=19@2"}, true, "", 1}, FaultCase{"stale", {"m0:stale@2"}, true, "", 1},
        FaultCase{"quality_beyond_the_limit",
                  {"m0:quality=19@2", "m0:quality=19@3", "m0:quality=19@4"},
                  false,
                  "bad_reading: quality 19",
                  3},
        FaultCase{"reboot", {"d5:reboot@2"}, false, "lost", 0, true},
        // Other reply styles of the same meter are read as well.
        FaultCase{"exponent", {"d5:exponent=e@2"}, true, ""}, FaultCase{"header", {"d5:header=h2@2"}, true, ""}),
    [](const ::testing::TestParamInfo<FaultCase>& param_info) { return param_info.param.name; });

class AcquisitionFaultsTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
};

TEST_F(AcquisitionFaultsTest, ADaemonKilledMidSessionLeavesAnIntactDatabaseAndAnInterruptedSession) {
  // Slow enough that a job of 40 readings is still running when the daemon is killed.
  AcquisitionRig rig(rig_options(dir_.path().string(), {"--time-scale", "0.2"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  auto p = rig.port;
  const long long session = new_session(p, "K1");
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();
  const auto sample = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(sample["state"], "succeeded") << sample << rig.logs();
  const auto before = get_json(p, session_path(session));

  const auto measurements_on_the_wire = [&] {
    const auto log = rig.sim->err();
    long n = 0;
    for (auto at = log.find("measured '"); at != std::string::npos; at = log.find("measured '", at + 1)) ++n;
    return n;
  };
  const auto measured_before = measurements_on_the_wire();
  const auto long_job = submit(p, session, {{"kind", "sample"}, {"count", 40}});
  const std::string job_path = "/api/v1/jobs/" + std::to_string(long_job["job_id"].get<long long>());
  // Killed once the job's first reading is done: in the middle of it (it ends failed, not
  // succeeded, below).
  ASSERT_TRUE(eventually([&] { return measurements_on_the_wire() > measured_before; })) << rig.logs();
  rig.daemon->send_signal(SIGKILL);
  EXPECT_EQ(rig.daemon->wait(10s).signal, SIGKILL);

  EXPECT_EQ(sqlite_text(rig.db_path(), "PRAGMA integrity_check"), "ok");
  rig.restart_daemon();
  ASSERT_TRUE(rig.ready()) << rig.logs();
  p = rig.port;
  EXPECT_EQ(sqlite_text(rig.db_path(), "PRAGMA integrity_check"), "ok");
  const auto after = get_json(p, session_path(session));
  EXPECT_EQ(after["state"], "interrupted") << after;
  EXPECT_EQ(after["measurements"], before["measurements"]);
  EXPECT_EQ(after["fits"], before["fits"]);
  const auto job = get_json(p, job_path);
  EXPECT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "interrupted") << job;
  EXPECT_EQ(samples_without_fit(rig.db_path()), 0);
  // An interrupted session takes no measurement until it is reopened.
  EXPECT_EQ(http_request(p, "POST", session_path(session) + "/measurements", json{{"kind", "sample"}}.dump()).status,
            409);
}

// The commands the simulator received, from its log of a fault that fires on every command and
// does nothing (late by 0 ms).
std::vector<std::string> commands_in(const std::string& sim_log) {
  static const std::string marker = "fault late=0 on '";
  std::vector<std::string> out;
  for (auto at = sim_log.find(marker); at != std::string::npos; at = sim_log.find(marker, at + 1))
    out.push_back(sim_log.substr(at + marker.size(), 2));
  return out;
}

TEST_F(AcquisitionFaultsTest, TwentyClientsAtOnceAreServedOneWholeMeasurementAfterAnother) {
  AcquisitionRig rig(rig_options(dir_.path().string(), {"--fault", "*:late=0"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "T1");
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();

  constexpr int kClients = 20;
  std::vector<json> accepted(kClients);
  {
    std::vector<std::jthread> clients;
    for (int i = 0; i < kClients; ++i)
      clients.emplace_back([&, i] {
        accepted[static_cast<std::size_t>(i)] =
            submit(p, session, {{"kind", "sample"}, {"label", "c" + std::to_string(i)}});
      });
  }
  std::vector<json> jobs;
  for (const auto& a : accepted) {
    ASSERT_TRUE(a.contains("job_id")) << a;
    jobs.push_back(wait_for_job(p, a));
  }
  std::ranges::sort(jobs, {}, [](const json& j) { return j["id"].get<long long>(); });
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    ASSERT_EQ(jobs[i]["state"], "succeeded") << jobs[i];
    if (i > 0) {
      EXPECT_GE(jobs[i]["started_at"].get<std::string>(), jobs[i - 1]["finished_at"].get<std::string>()) << i;
    }
  }
  // Stored in job order, each measurement's readings after the previous one's.
  const auto detail = get_json(p, session_path(session));
  ASSERT_EQ(detail["measurements"].size(), kClients + 1u);
  for (std::size_t i = 1; i < detail["measurements"].size(); ++i) {
    const auto& m = detail["measurements"][i];
    EXPECT_EQ(m["provenance"]["job_id"], jobs[i - 1]["id"]);
    EXPECT_GE(m["provenance"]["started_at"].get<std::string>(),
              detail["measurements"][i - 1]["provenance"]["finished_at"].get<std::string>());
  }
  // On the wire: first contact and identification, then whole measurements, one after another.
  const std::vector<std::string> measurement = {"S0", "M0", "D5", "D1", "D2"};
  auto commands = commands_in(rig.sim->err());
  const auto first_setup = std::ranges::find(commands, "S0");
  ASSERT_NE(first_setup, commands.end()) << rig.sim->err();
  commands.erase(commands.begin(), first_setup);
  // Once the last job has ended, the daemon may check on the idle meter (D110, D120).
  const auto last_read = std::ranges::find(commands | std::views::reverse, "D2");
  commands.erase(last_read.base(), commands.end());
  ASSERT_EQ(commands.size(), measurement.size() * (kClients + 1)) << rig.sim->err();
  for (std::size_t i = 0; i < commands.size(); ++i)
    EXPECT_EQ(commands[i], measurement[i % measurement.size()]) << "command " << i;
}

// A radiance file whose scenes the meter sees in turn: a white, the same white under a lamp 20 %
// brighter, then skin-like grey.
std::string scenes_file(const ScratchDirectory& dir) {
  const std::string path = dir.file("scenes.csv");
  std::ofstream(path) << "wavelength_nm,white,brighter_white,grey\n380,0.05,0.06,0.02\n780,0.05,0.06,0.02\n";
  return path;
}

TEST_F(AcquisitionFaultsTest, ASampleAfterAFailedWhiteNamesTheWhiteJobThatFailed) {
  // The white's three readings all overload: it fails and stores nothing.
  AcquisitionRig rig(rig_options(dir_.path().string(), {"--fault", "m0:quality=19@1", "--fault", "m0:quality=19@2",
                                                        "--fault", "m0:quality=19@3"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "W1");
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "failed") << white;
  const std::string white_job = std::to_string(white["id"].get<long long>());

  const auto sample = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(sample["state"], "failed") << sample;
  const std::string error = job_error_text(sample);
  EXPECT_TRUE(error.starts_with("no_white: ")) << error;
  EXPECT_NE(error.find("(job " + white_job + ") failed"), std::string::npos) << error;

  // Measured again, the white is in force for the samples after it.
  ASSERT_EQ(wait_for_job(p, submit(p, session, {{"kind", "white"}}))["state"], "succeeded");
  EXPECT_EQ(wait_for_job(p, submit(p, session, {{"kind", "sample"}}))["state"], "succeeded");
}

TEST_F(AcquisitionFaultsTest, AChangedLampWarnsOnItsWhiteAndOnSamplesMeasuredAgainstIt) {
  auto options = rig_options(dir_.path().string(), {"--radiance", scenes_file(dir_)});
  options.default_scenes = false;
  AcquisitionRig rig(options);
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "L1");
  const auto first = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(first["state"], "succeeded") << first << rig.logs();
  EXPECT_TRUE(first["result"]["warnings"].empty()) << first;
  const auto second = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(second["state"], "succeeded") << second;
  ASSERT_EQ(second["result"]["warnings"].size(), 1u) << second;
  const auto lamp = second["result"]["warnings"][0].get<std::string>();
  EXPECT_TRUE(lamp.starts_with("lamp_changed:")) << lamp;
  EXPECT_NE(lamp.find("+20.0 %"), std::string::npos) << lamp;
  const auto sample = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(sample["state"], "succeeded") << sample;
  ASSERT_EQ(sample["result"]["warnings"].size(), 1u) << sample;  // not stale: the default age is 30 min
  EXPECT_TRUE(sample["result"]["warnings"][0].get<std::string>().starts_with("lamp_changed:")) << sample;
  const auto stored =
      get_json(p, "/api/v1/measurements/" + std::to_string(sample["result"]["measurement_id"].get<long long>()));
  EXPECT_EQ(stored["warnings"], sample["result"]["warnings"]);
  EXPECT_EQ(get_json(p, "/api/v1/measurements/" +
                            std::to_string(second["result"]["measurement_id"].get<long long>()))["warnings"],
            second["result"]["warnings"]);
}

TEST_F(AcquisitionFaultsTest, ASampleAgainstAnOldWhiteWarnsAndSettingsComeFromTheConfigFile) {
  const std::string config = dir_.file("skinspecd.json");
  std::ofstream(config) << R"({"white_max_age_s": 0.000001, "lamp_change_tolerance": 0.5, "max_rejected_readings": 0})";
  AcquisitionRig rig(rig_options(dir_.path().string(), {"--fault", "m0:quality=18@3"}, {"--config", config}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "A1");
  ASSERT_EQ(wait_for_job(p, submit(p, session, {{"kind", "white"}}))["state"], "succeeded");
  const auto sample = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(sample["state"], "succeeded") << sample;
  ASSERT_EQ(sample["result"]["warnings"].size(), 1u) << sample;
  EXPECT_TRUE(sample["result"]["warnings"][0].get<std::string>().starts_with("white_stale:")) << sample;
  // max_rejected_readings 0: the first bad reading fails the job, and is kept.
  const auto rejected = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(rejected["state"], "failed") << rejected;
  EXPECT_EQ(rejected["error"]["code"], "bad_reading") << rejected;
  EXPECT_TRUE(rejected["error"]["message"].get<std::string>().starts_with("quality 18")) << rejected;
  EXPECT_EQ(rejected["result"]["rejected_reading_ids"].size(), 1u) << rejected;
  EXPECT_EQ(get_json(p, session_path(session))["rejected_readings"].size(), 1u);

  // Settings out of range are refused at start.
  const auto refused = run_process(std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd",
                                   {"--db", dir_.file("other.db"), "--lamp-change-tolerance", "-1"});
  EXPECT_EQ(refused.exit_status, 2) << refused.describe();
  EXPECT_NE(refused.err.find("lamp_change_tolerance"), std::string::npos) << refused.err;
}

}  // namespace
}  // namespace skinspec::testing
