// Two benches on one PostgreSQL database whose daemons' clocks disagree by ten minutes (libfaketime
// on each daemon alone) judge each other by the database server's clock (docs/store.md,
// "Benches"): neither is taken for silent while it beats, and one that dies is still found.

#include <gtest/gtest.h>

#include <csignal>
#include <string>
#include <thread>
#include <vector>

#include "bench_daemons.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

// A daemon's environment that moves its wall clock by `offset` ("+5m") through libfaketime, and
// leaves its steady clock, by which it times its heartbeats and timeouts, alone.
std::vector<std::string> clock_moved(const std::string& offset) {
  return {"LD_PRELOAD=" SKINSPEC_TEST_LIBFAKETIME, "FAKETIME=" + offset, "FAKETIME_DONT_FAKE_MONOTONIC=1"};
}

// Bench A's machine is 5 minutes behind, bench B's 5 minutes ahead. By their own clocks each
// would find the other's heartbeats 10 minutes off: B would take A, alive, for silent and refuse
// its jobs, and A would take B's heartbeats for fresh for 10 minutes after B died. Judged by the
// server's clock, neither happens.
TEST(ClockSkewTest, BenchesWhoseClocksDisagreeByTenMinutesJudgeEachOtherByTheServersClock) {
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
