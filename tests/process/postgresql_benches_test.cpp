// Two benches on one PostgreSQL database, each a skinspecd with its own skinspec-sim meter: both
// list every session; a job for bench A's session posted through bench B's daemon runs on A's
// meter, and its progress is followed through B; a daemon killed mid-job has its job
// interrupted by the other, which goes on serving and refuses jobs for the dead bench with 409
// bench_not_running; and benches whose machines' clocks disagree by ten minutes judge each other
// by the database server's (docs/store.md, "Benches").

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <ctime>
#include <functional>
#include <optional>
#include <set>
#include <thread>

#include "bench_daemons.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

std::set<long long> session_ids(unsigned short port) {
  std::set<long long> ids;
  const auto page = get_json(port, "/api/v1/sessions?limit=1000");
  for (const auto& s : page["sessions"]) ids.insert(s["id"].get<long long>());
  return ids;
}

// The SSE events of job `id` through `port`, until the stream ends.
std::vector<json> job_events(unsigned short port, long long id) {
  std::vector<json> events;
  const auto reply = follow_events(
      port, "/api/v1/jobs/" + std::to_string(id) + "/events",
      [&](const std::string& text) {
        const auto data = text.find("data: ");
        if (data != std::string::npos) events.push_back(json::parse(text.substr(data + 6), nullptr, false));
        return true;
      },
      120s);
  EXPECT_EQ(reply.status, 200) << reply.body;
  return events;
}

// An API time, "2026-12-02T16:10:09.355436Z".
std::chrono::system_clock::time_point time_of(const std::string& text) {
  std::tm parts{};
  int micros = 0;
  if (std::sscanf(text.c_str(), "%d-%d-%dT%d:%d:%d.%dZ", &parts.tm_year, &parts.tm_mon, &parts.tm_mday, &parts.tm_hour,
                  &parts.tm_min, &parts.tm_sec, &micros) != 7)
    throw std::runtime_error("not an API time: " + text);
  parts.tm_year -= 1900;
  parts.tm_mon -= 1;
  return std::chrono::system_clock::from_time_t(timegm(&parts)) + std::chrono::microseconds(micros);
}

// A daemon's environment that moves its wall clock by `offset` ("+5m") through libfaketime, and
// leaves its steady clock, by which it times its heartbeats and timeouts, alone.
std::vector<std::string> clock_moved(const std::string& offset) {
  return {"LD_PRELOAD=" SKINSPEC_TEST_LIBFAKETIME, "FAKETIME=" + offset, "FAKETIME_DONT_FAKE_MONOTONIC=1"};
}

TEST(PostgresqlBenchesTest, TwoBenchesSeeEverySessionAndAJobPostedThroughTheOtherRunsOnItsOwnBench) {
  const auto uri = postgres_cluster().uri(postgres_cluster().create_database());
  Bench a(uri, "bench-a", "0.05");
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  Bench b(uri, "bench-b", "0");
  ASSERT_TRUE(b.rig->ready()) << b.rig->logs();

  const long long on_a = new_session(a.port(), "A1");
  const long long on_b = new_session(b.port(), "B1");
  ASSERT_NE(on_a, 0);
  ASSERT_NE(on_b, 0);
  for (const auto port : {a.port(), b.port()}) {
    const auto ids = session_ids(port);
    EXPECT_TRUE(ids.contains(on_a) && ids.contains(on_b)) << get_json(port, "/api/v1/sessions?limit=1000");
    EXPECT_EQ(get_json(port, "/api/v1/sessions/" + std::to_string(on_a))["bench"], "bench-a");
    EXPECT_EQ(get_json(port, "/api/v1/sessions/" + std::to_string(on_b))["bench"], "bench-b");
    const auto listed = get_json(port, "/api/v1/benches");
    ASSERT_EQ(listed["benches"].size(), 2u) << listed;
    for (const auto& bench : listed["benches"]) {
      EXPECT_EQ(bench["state"], "running") << bench;
      EXPECT_EQ(bench["this"], bench["name"] == listed["bench"]) << listed;
      EXPECT_TRUE(bench["instrument"].contains("state")) << bench;
    }
  }

  // The white on A through A, then a sample of A's session through B.
  ASSERT_EQ(wait_for_job(a.port(), submit(a.port(), on_a, {{"kind", "white"}}))["state"], "succeeded") << a.rig->logs();
  const auto accepted = submit(b.port(), on_a, {{"kind", "sample"}, {"count", 3}});
  ASSERT_TRUE(accepted["id"].is_number_integer()) << accepted << b.rig->logs();
  EXPECT_EQ(accepted["bench"], "bench-a");
  const auto events = job_events(b.port(), accepted["id"].get<long long>());
  const auto last_event_at = std::chrono::system_clock::now();
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back()["state"], "succeeded") << events.back() << a.rig->logs() << b.rig->logs();
  // Readings counted while it ran can only have come from bench A, which runs it.
  const bool counted = std::ranges::any_of(
      events, [](const json& e) { return e["state"] == "running" && e["progress"]["readings_done"].get<int>() > 0; });
  EXPECT_TRUE(counted) << json(events).dump();
  // Its end reached the follower through B when it happened, not at B's re-read of the record
  // after a quiet 15 s.
  EXPECT_LT(last_event_at - time_of(events.back()["finished_at"].get<std::string>()), 5s) << events.back();
  const auto measurement = events.back()["result"]["measurement_id"];
  ASSERT_TRUE(measurement.is_number_integer()) << events.back();
  const auto stored = get_json(b.port(), "/api/v1/measurements/" + measurement.dump());
  const auto white = get_json(a.port(), "/api/v1/sessions/" + std::to_string(on_a))["measurements"][0];
  ASSERT_TRUE(white["provenance"]["instrument_id"].is_number_integer()) << white;
  EXPECT_EQ(stored["provenance"]["instrument_id"], white["provenance"]["instrument_id"]) << "bench A's meter";

  // Through B: a running job of A's is cancelled by A, and a queued one never runs.
  const auto running = submit(a.port(), on_a, {{"kind", "sample"}, {"count", 20}});
  const auto queued = submit(a.port(), on_a, {{"kind", "sample"}});
  const auto running_path = "/api/v1/jobs/" + running["id"].dump();
  ASSERT_TRUE(eventually([&] { return get_json(b.port(), running_path)["state"] == "running"; }, 20s));
  for (const auto& job : {queued, running}) {
    const auto cancelled = http_request(b.port(), "DELETE", "/api/v1/jobs/" + job["id"].dump());
    EXPECT_EQ(cancelled.status, 200) << cancelled.body;
  }
  const auto stopped = wait_for_job(a.port(), running);
  EXPECT_EQ(stopped["state"], "cancelled") << stopped;
  EXPECT_LT(stopped["progress"]["readings_done"].get<int>(), 20) << stopped;
  const auto never = wait_for_job(a.port(), queued);
  EXPECT_EQ(never["state"], "cancelled") << never;
  EXPECT_TRUE(never["started_at"].is_null()) << never;
}

TEST(PostgresqlBenchesTest, ABenchKilledMidJobHasItsJobInterruptedByTheOtherWhichGoesOnServing) {
  const auto database = postgres_cluster().create_database();
  const auto uri = postgres_cluster().uri(database);
  Bench a(uri, "bench-a", "0.05", {"--lease", "2"});
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  Bench b(uri, "bench-b", "0");
  ASSERT_TRUE(b.rig->ready()) << b.rig->logs();
  const long long measured = new_session(a.port(), "A2");
  const long long idle = new_session(a.port(), "A3");
  ASSERT_EQ(wait_for_job(a.port(), submit(a.port(), measured, {{"kind", "white"}}))["state"], "succeeded");
  const auto accepted = submit(a.port(), measured, {{"kind", "sample"}, {"count", 10}});
  const auto path = "/api/v1/jobs/" + accepted["id"].dump();
  ASSERT_TRUE(eventually([&] { return get_json(b.port(), path)["state"] == "running"; }, 20s)) << a.rig->logs();
  a.rig->stop_daemon(SIGKILL);

  json job;
  for (auto until = std::chrono::steady_clock::now() + 30s; std::chrono::steady_clock::now() < until;) {
    job = get_json(b.port(), path);
    if (job["state"] != "running") break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(job["state"], "failed") << job << b.rig->logs();
  EXPECT_EQ(job["error"]["code"], "interrupted");
  EXPECT_EQ(get_json(b.port(), "/api/v1/sessions/" + std::to_string(measured))["state"], "interrupted");
  EXPECT_EQ(get_json(b.port(), "/api/v1/sessions/" + std::to_string(idle))["state"], "open");
  EXPECT_EQ(bench_named(b.port(), "bench-a")["state"], "silent") << get_json(b.port(), "/api/v1/benches");

  const auto refused = http_request(b.port(), "POST", "/api/v1/sessions/" + std::to_string(idle) + "/measurements",
                                    json{{"kind", "white"}}.dump());
  EXPECT_EQ(refused.status, 409) << refused.body;
  EXPECT_EQ(refused.json()["error"]["code"], "bench_not_running") << refused.body;
  EXPECT_EQ(postgres_cluster().integer(database, "SELECT count(*) FROM jobs"), 2) << "nothing of the refused job";

  // B goes on measuring on its own bench.
  const long long on_b = new_session(b.port(), "B2");
  EXPECT_EQ(wait_for_job(b.port(), submit(b.port(), on_b, {{"kind", "white"}}))["state"], "succeeded");
}

// Bench A's machine is 5 minutes behind, bench B's 5 minutes ahead. By their own clocks each
// would find the other's heartbeats 10 minutes off: B would take A, alive, for silent and refuse
// its jobs, and A would take B's heartbeats for fresh for 10 minutes after B died. Judged by the
// server's clock, neither happens.
TEST(PostgresqlBenchesTest, BenchesWhoseClocksDisagreeByTenMinutesJudgeEachOtherByTheServersClock) {
  const auto uri = postgres_cluster().uri(postgres_cluster().create_database());
  Bench a(uri, "bench-a", "0.05", {"--lease", "2"}, clock_moved("-5m"));
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  Bench b(uri, "bench-b", "0.05", {"--lease", "2"}, clock_moved("+5m"));
  ASSERT_TRUE(b.rig->ready()) << b.rig->logs();
  // The clocks are moved: each bench's start is written by its own.
  const auto started = [&](const std::string& name) {
    return time_of(bench_named(a.port(), name)["started_at"].get<std::string>());
  };
  EXPECT_GT(started("bench-b") - started("bench-a"), 9min) << get_json(a.port(), "/api/v1/benches");

  // Both running to both, through heartbeats over more than twice the lease.
  for (const auto until = std::chrono::steady_clock::now() + 5s; std::chrono::steady_clock::now() < until;) {
    for (const auto port : {a.port(), b.port()})
      for (const auto* name : {"bench-a", "bench-b"})
        ASSERT_EQ(bench_named(port, name)["state"], "running")
            << name << " through " << port << ": " << get_json(port, "/api/v1/benches");
    std::this_thread::sleep_for(250ms);
  }
  // Each runs the jobs posted through the other.
  const long long on_a = new_session(a.port(), "A4");
  const long long on_b = new_session(b.port(), "B4");
  const auto white_on_a = submit(b.port(), on_a, {{"kind", "white"}});
  ASSERT_TRUE(white_on_a["id"].is_number_integer()) << white_on_a << b.rig->logs();
  EXPECT_EQ(wait_for_job(a.port(), white_on_a)["state"], "succeeded") << a.rig->logs();
  const auto white_on_b = submit(a.port(), on_b, {{"kind", "white"}});
  ASSERT_TRUE(white_on_b["id"].is_number_integer()) << white_on_b << a.rig->logs();
  EXPECT_EQ(wait_for_job(b.port(), white_on_b)["state"], "succeeded") << b.rig->logs();

  // B, ahead, dies mid-job; A, behind, finds it within seconds, not ten minutes.
  const auto running = submit(b.port(), on_b, {{"kind", "sample"}, {"count", 20}});
  const auto path = "/api/v1/jobs/" + running["id"].dump();
  ASSERT_TRUE(eventually([&] { return get_json(a.port(), path)["state"] == "running"; }, 20s)) << b.rig->logs();
  b.rig->stop_daemon(SIGKILL);
  const auto ended = [&] {
    const auto state = get_json(a.port(), path)["state"];
    return state != "queued" && state != "running";
  };
  ASSERT_TRUE(eventually(ended, 30s)) << get_json(a.port(), path) << a.rig->logs();
  const auto job = get_json(a.port(), path);
  EXPECT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "interrupted") << job;
  EXPECT_EQ(bench_named(a.port(), "bench-b")["state"], "silent") << get_json(a.port(), "/api/v1/benches");
}

}  // namespace
}  // namespace skinspec::testing
