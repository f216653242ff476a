// A soak of acquisition jobs through the real skinspecd and skinspec-sim with seeded random
// faults on every command's reply: lost replies, late ones, cut, garbled and bit-flipped ones,
// dropped lines, and the quality codes a real meter gives. The faults are single (a command
// asked again after one is spared): no job may fail for one of them, and the jobs' durations,
// from their records, must stay short at time scale 0. scripts/soak runs it with more jobs
// (SKINSPEC_SOAK_JOBS) and other seeds (SKINSPEC_SOAK_SEED).

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "support/job_error.hpp"
#include "support/soak_size.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;
using Micros = std::chrono::microseconds;

constexpr double kFaultRate = 0.05;  // per command, as in the field campaign that found the holes
// A fixed integration time that suits the simulated white and skin: a silent M0 then costs
// 2 x 600 ms plus the meter's overhead, not the 30 s adaptive integration is allowed.
constexpr int kIntegrationMs = 600;
constexpr auto kP95Limit = 2s;

// "2024-05-01T12:00:00.123456Z", as the API writes times.
std::chrono::sys_time<Micros> parse_api_time(const std::string& text) {
  int year = 0, month = 0, day = 0, hour = 0, minute = 0, second = 0;
  long micros = 0;
  const int fields =
      std::sscanf(text.c_str(), "%d-%d-%dT%d:%d:%d.%6ldZ", &year, &month, &day, &hour, &minute, &second, &micros);
  EXPECT_EQ(fields, 7) << text;
  const auto date = std::chrono::sys_days(std::chrono::year(year) / month / day);
  return date + std::chrono::hours(hour) + std::chrono::minutes(minute) + std::chrono::seconds(second) + Micros(micros);
}

Micros duration_of(const json& job) {
  return parse_api_time(job["finished_at"].get<std::string>()) - parse_api_time(job["started_at"].get<std::string>());
}

double ms(Micros t) { return static_cast<double>(t.count()) / 1000; }

// The faults the simulator fired, from its log lines "fault truncate on 'D5'", by command and
// by kind ("truncate", "quality=18" counted as "quality").
struct FiredFaults {
  std::map<std::string, int> by_command, by_kind;
  int total = 0;
};

FiredFaults fired_faults(const std::string& sim_log) {
  static const std::string marker = "fault ";
  FiredFaults fired;
  for (auto at = sim_log.find(marker); at != std::string::npos; at = sim_log.find(marker, at + 1)) {
    const auto on = sim_log.find(" on '", at);
    const auto end = sim_log.find('\'', on + 5);
    if (on == std::string::npos || end == std::string::npos) break;
    std::string kind = sim_log.substr(at + marker.size(), on - at - marker.size());
    kind = kind.substr(0, kind.find('='));
    std::string command = sim_log.substr(on + 5, end - on - 5);
    if (command.starts_with("S")) command = "S";
    ++fired.by_command[command];
    ++fired.by_kind[kind];
    ++fired.total;
  }
  return fired;
}

class AcquisitionSoakTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
};

TEST_F(AcquisitionSoakTest, NoJobFailsForASingleLostOrDamagedReplyAndJobsStayShort) {
  const int job_count = soak_size("SKINSPEC_SOAK_JOBS", 120);  // a white, then samples, in one session
  const std::string seed = std::to_string(soak_size("SKINSPEC_SOAK_SEED", 13));
  AcquisitionRig rig(rig_options(dir_.path().string(),
                                 {"--fault-rate", std::to_string(kFaultRate), "--fault-gap", "1", "--seed", seed}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "SOAK");
  ASSERT_NE(session, 0);

  const auto started = std::chrono::steady_clock::now();
  std::vector<json> accepted;
  for (int i = 0; i < job_count; ++i) {
    const json body = {{"kind", i == 0 ? "white" : "sample"}, {"integration_ms", kIntegrationMs}};
    accepted.push_back(submit(p, session, body));
    ASSERT_TRUE(accepted.back().contains("job_id")) << accepted.back();
  }
  std::vector<json> jobs;
  for (const auto& job : accepted) jobs.push_back(wait_for_job(p, job, 120s));
  const auto wall = std::chrono::steady_clock::now() - started;

  std::vector<Micros> durations;
  int failed = 0, failed_on_quality = 0, remeasured = 0, rejected = 0;
  for (const auto& job : jobs) {
    const std::string state = job.value("state", "");
    ASSERT_TRUE(state == "succeeded" || state == "failed") << job;
    durations.push_back(duration_of(job));
    if (state == "succeeded") {
      for (const auto& warning : job["result"]["warnings"])
        remeasured += warning.get<std::string>().starts_with("remeasured:");
      rejected += static_cast<int>(job["result"]["rejected_reading_ids"].size());
      continue;
    }
    // Only the meter's own verdict may end a job: more readings with a bad quality code than
    // the policy allows. A lost or damaged reply never may.
    const std::string error = job_error_text(job);
    if (error.starts_with("bad_reading:") && error.find("readings rejected") != std::string::npos) {
      ++failed_on_quality;
      continue;
    }
    ++failed;
    ADD_FAILURE() << "job failed: " << job;
  }

  std::ranges::sort(durations);
  const auto at = [&](double q) {
    return durations[static_cast<std::size_t>(q * static_cast<double>(durations.size() - 1))];
  };
  const Micros p95 = at(0.95);
  const FiredFaults fired = fired_faults(rig.sim->err());
  std::string by_command, by_kind;
  for (const auto& [command, n] : fired.by_command) by_command += " " + command + " " + std::to_string(n);
  for (const auto& [kind, n] : fired.by_kind) by_kind += " " + kind + " " + std::to_string(n);
  std::printf(
      "soak: %d jobs in %.1f s at fault rate %.2f (seed %s): %d failed, %d failed on quality codes, "
      "%d readings rejected, %d measured again\n"
      "soak: job duration p50 %.0f ms, p95 %.0f ms, max %.0f ms\n"
      "soak: %d faults fired; by command:%s; by kind:%s\n",
      job_count, std::chrono::duration<double>(wall).count(), kFaultRate, seed.c_str(), failed, failed_on_quality,
      rejected, remeasured, ms(at(0.5)), ms(p95), ms(durations.back()), fired.total, by_command.c_str(),
      by_kind.c_str());

  EXPECT_GE(static_cast<int>(jobs.size()), 100);
  EXPECT_EQ(failed, 0) << rig.logs();
  EXPECT_LE(p95, kP95Limit) << "p95 " << ms(p95) << " ms";
  // The soak is only worth its name if the faults reached every command of a measurement, in
  // every kind a line can do to a reply.
  for (const std::string command : {"S", "M0", "D5", "D1", "D2"})
    EXPECT_GE(fired.by_command.count(command) ? fired.by_command.at(command) : 0, 2) << command;
  for (const std::string kind : {"no-answer", "late", "truncate", "garbage", "bitflip", "drop-line", "quality"})
    EXPECT_GE(fired.by_kind.count(kind) ? fired.by_kind.at(kind) : 0, 1) << kind;
}

}  // namespace
}  // namespace skinspec::testing
