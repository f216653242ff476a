// Two benches on one PostgreSQL database, each a skinspecd with its own skinspec-sim meter: both
// list every session; a job for bench A's session posted through bench B's daemon runs on A's
// meter, and its progress is followed through B; a daemon killed mid-job has its job
// interrupted by the other, which goes on serving and refuses jobs for the dead bench with 409
// bench_not_running (docs/store.md, "Benches").

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

}  // namespace
}  // namespace skinspec::testing
