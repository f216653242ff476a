// The database server goes away under skinspecd with a measurement in flight, on a throwaway
// cluster of each test's own: stopped at once ("immediate", as a crash or an update's restart)
// and started again; cut off from one bench by the network for longer than its lease; made
// read-only. Each time the job is stored whole once the server is back, reads answer 503 with
// Retry-After while it cannot serve them, the daemon serves again within seconds without a
// restart, and no bench is taken for dead; an import whose end the server missed is recorded
// interrupted once it is back (docs/store.md, "Outages").

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <thread>

#include "bench_daemons.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/testkit/unix_relay.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

// A white measured in a new session of `bench`, then a sample of `count` readings started
// (its first reading in), and that job as accepted.
struct JobInFlight {
  long long session = 0;
  json accepted;
  std::string path;

  JobInFlight(const Bench& bench, int count) {
    session = new_session(bench.port(), "outage");
    EXPECT_NE(session, 0);
    EXPECT_EQ(wait_for_job(bench.port(), submit(bench.port(), session, {{"kind", "white"}}))["state"], "succeeded")
        << bench.rig->logs();
    accepted = submit(bench.port(), session, {{"kind", "sample"}, {"count", count}});
    path = "/api/v1/jobs/" + accepted["id"].dump();
    const bool measuring =
        eventually([&] { return get_json(bench.port(), path)["progress"]["readings_done"].get<int>() >= 1; }, 20s);
    EXPECT_TRUE(measuring) << get_json(bench.port(), path) << bench.rig->logs();
  }
};

// What the database holds of `job`: its state, and how many measurements and fits name it.
struct Stored {
  std::string state;
  long long measurements = 0;
  long long fits = 0;
};

Stored stored_of(const PostgresCluster& cluster, const std::string& database, const json& job) {
  const auto id = job["id"].dump();
  return {cluster.text(database, "SELECT state FROM jobs WHERE id = " + id),
          cluster.integer(database, "SELECT count(*) FROM measurements WHERE job_id = " + id),
          cluster.integer(database,
                          "SELECT count(*) FROM fits f JOIN measurements m ON m.id = f.measurement_id "
                          "WHERE m.job_id = " +
                              id)};
}

// A read refused for want of the database: 503, a JSON error with `code`, and Retry-After.
void expect_unavailable(const HttpReply& reply, const std::string& code) {
  EXPECT_EQ(reply.status, 503) << reply.body;
  EXPECT_EQ(reply.json()["error"]["code"], code) << reply.body;
  EXPECT_FALSE(reply.header("retry-after").empty()) << reply.body;
}

// Serves `session` again (200) within seconds of the server's return.
void expect_serving_again(const Bench& bench, long long session) {
  EXPECT_TRUE(eventually([&] { return http_request(bench.port(), "GET", session_path(session)).status == 200; }, 10s))
      << bench.rig->logs();
}

TEST(PostgresqlOutageTest, AServerStoppedAtOnceMidJobLosesNothingAndIsServedAgainWithoutARestart) {
  PostgresCluster cluster;
  const auto database = cluster.create_database();
  Bench a(cluster.uri(database), "bench-a", "0.05", {"--lease", "2"});
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  JobInFlight job(a, 8);

  cluster.stop("immediate");
  expect_unavailable(http_request(a.port(), "GET", session_path(job.session)), "database_unreachable");
  // Nothing is acknowledged that could be lost: a new job is refused, not queued in memory.
  expect_unavailable(
      http_request(a.port(), "POST", session_path(job.session) + "/measurements", json{{"kind", "white"}}.dump()),
      "database_unreachable");
  std::this_thread::sleep_for(4s);  // the meter's 8 readings are in; their store waits
  cluster.start();

  expect_serving_again(a, job.session);
  const auto ended = wait_for_job(a.port(), job.accepted, 20s);
  EXPECT_EQ(ended["state"], "succeeded") << ended << a.rig->logs();
  const auto stored = stored_of(cluster, database, job.accepted);
  EXPECT_EQ(stored.state, "succeeded");
  EXPECT_EQ(stored.measurements, 1);
  EXPECT_EQ(stored.fits, 1);
  EXPECT_EQ(bench_named(a.port(), "bench-a")["state"], "running");
  const auto next = submit(a.port(), job.session, {{"kind", "sample"}});
  EXPECT_EQ(wait_for_job(a.port(), next)["state"], "succeeded") << a.rig->logs();
}

// Bench A reaches the server through a relay that goes down for 6 s (a lease of 2 s); bench B
// stays connected. A's backend lives on behind the cut holding A's writer lock, so B, though it
// sees A's heartbeat grow old, never recovers A's job; A, reconnected, ends that backend, takes
// its lock again and stores the job.
TEST(PostgresqlOutageTest, ABenchCutOffForLongerThanItsLeaseIsNotTakenForDeadAndStoresItsJob) {
  PostgresCluster cluster;
  const auto database = cluster.create_database();
  ScratchDirectory relay_dir;
  UnixRelay relay(relay_dir.path() / cluster.socket().filename(), cluster.socket());
  const auto relayed = "postgresql://skinspec@/" + database + "?host=" + relay_dir.path().string();
  Bench a(relayed, "bench-a", "0.05", {"--lease", "2"});
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  Bench b(cluster.uri(database), "bench-b", "0", {"--lease", "2"});
  ASSERT_TRUE(b.rig->ready()) << b.rig->logs();
  // Readings enough to outlast the wait for the first one: with 8, a ThreadSanitizer build on
  // one busy core once saw the first reading late, and the job ended and was stored before the
  // cut, leaving nothing in flight to check.
  JobInFlight job(a, 24);

  relay.go_down();
  std::this_thread::sleep_for(3s);
  expect_unavailable(http_request(a.port(), "GET", session_path(job.session)), "database_unreachable");
  std::this_thread::sleep_for(3s);
  EXPECT_EQ(get_json(b.port(), job.path)["state"], "running") << "taken for dead: " << b.rig->logs();
  relay.come_back();

  expect_serving_again(a, job.session);
  const auto ended = wait_for_job(b.port(), job.accepted, 20s);
  EXPECT_EQ(ended["state"], "succeeded") << ended << a.rig->logs() << "\nbench-b's " << b.rig->logs();
  const auto stored = stored_of(cluster, database, job.accepted);
  EXPECT_EQ(stored.measurements, 1);
  EXPECT_EQ(stored.fits, 1);
  EXPECT_TRUE(eventually([&] { return bench_named(b.port(), "bench-a")["state"] == "running"; }, 5s))
      << get_json(b.port(), "/api/v1/benches");
}

// The server read-only (default_transaction_read_only, as a standby or a full-disk guard makes
// it): reads go on, writes answer 503, and the job's end waits to be stored.
TEST(PostgresqlOutageTest, AServerMadeReadOnlyMidJobServesReadsAndStoresTheJobOnceItTakesWrites) {
  PostgresCluster cluster;
  const auto database = cluster.create_database();
  // The harness's own role keeps writing, to make the server writable again.
  cluster.execute("postgres", "ALTER ROLE admin SET default_transaction_read_only = off");
  Bench a(cluster.uri(database), "bench-a", "0.05", {"--lease", "2"});
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  JobInFlight job(a, 8);

  cluster.execute("postgres", "ALTER SYSTEM SET default_transaction_read_only = on");
  cluster.execute("postgres", "SELECT pg_reload_conf()");
  std::this_thread::sleep_for(4s);  // the readings are in; their store is refused
  EXPECT_EQ(http_request(a.port(), "GET", session_path(job.session)).status, 200);
  expect_unavailable(
      http_request(a.port(), "POST", session_path(job.session) + "/measurements", json{{"kind", "white"}}.dump()),
      "database_read_only");
  EXPECT_EQ(stored_of(cluster, database, job.accepted).state, "running");
  cluster.execute("postgres", "ALTER SYSTEM RESET default_transaction_read_only");
  cluster.execute("postgres", "SELECT pg_reload_conf()");

  const auto ended = wait_for_job(a.port(), job.accepted, 20s);
  EXPECT_EQ(ended["state"], "succeeded") << ended << a.rig->logs();
  const auto stored = stored_of(cluster, database, job.accepted);
  EXPECT_EQ(stored.measurements, 1);
  EXPECT_EQ(stored.fits, 1);
}

// `rows` spectra as a file of spectra from another program: the example file's first spectrum
// under new names.
std::string spectra_file(std::size_t rows) {
  std::istringstream example(file_bytes(std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/import-rows-percent.csv"));
  std::string header, row;
  std::getline(example, header);
  std::getline(example, row);
  std::string out = header + "\n";
  for (std::size_t i = 0; i < rows; ++i) out += "\"s" + std::to_string(i) + "\"" + row.substr(row.find(',')) + "\n";
  return out;
}

// An import's end finds the server gone: it stores nothing, and its record, left running, is
// ended as interrupted at the daemon's first heartbeat once the server is back, with no restart.
TEST(PostgresqlOutageTest, AnImportWhoseEndFindsTheServerGoneIsRecordedInterruptedOnceItIsBack) {
  PostgresCluster cluster;
  const auto database = cluster.create_database();
  Bench a(cluster.uri(database), "bench-a", "0", {"--lease", "2"});
  ASSERT_TRUE(a.rig->ready()) << a.rig->logs();
  const long long session = new_session(a.port(), "import");
  const auto posted = http_request(a.port(), "POST", session_path(session) + "/imports", spectra_file(20000),
                                   {{"Content-Type", "text/csv"}});
  ASSERT_EQ(posted.status, 202) << posted.body;
  cluster.stop("immediate");  // while its 20,000 spectra are fitted
  const auto not_stored = "event=job_end_not_stored job=" + posted.json()["id"].dump();
  ASSERT_TRUE(eventually([&] { return a.rig->daemon->err().find(not_stored) != std::string::npos; }, 60s))
      << a.rig->logs();
  cluster.start();

  expect_serving_again(a, session);
  const auto ended = wait_for_job(a.port(), posted.json(), 30s);
  EXPECT_EQ(ended["state"], "failed") << ended;
  // Its record, queued or running when the server went, is ended too.
  const auto recorded = [&] {
    return cluster.text(database, "SELECT state FROM jobs WHERE id = " + posted.json()["id"].dump());
  };
  ASSERT_TRUE(eventually([&] { return recorded() == "failed"; }, 10s)) << recorded() << a.rig->logs();
  const auto job = get_json(a.port(), "/api/v1/jobs/" + posted.json()["id"].dump());
  EXPECT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "interrupted") << job;
  EXPECT_EQ(cluster.integer(database, "SELECT count(*) FROM measurements"), 0);
}

}  // namespace
}  // namespace skinspec::testing
