// skinspecd and skinspec on a PostgreSQL database of the test program's throwaway cluster: a
// whole acquisition session stored there and read back by `skinspec export --db URI`; a lab's
// SQLite file moved there by `skinspec migrate-db` and back, byte for byte; a daemon
// killed mid-job leaves the job interrupted and nothing half stored; and the start refused with
// exit status 2, nothing written, for an unreachable server, a refused password, another
// application's database and a role that only reads.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <fstream>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

const std::string kSkinspec = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec";
const std::string kSkinspecd = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd";

struct Database {
  std::string name = postgres_cluster().create_database();
  std::string uri = postgres_cluster().uri(name);
  long long count(const std::string& table) const {
    return postgres_cluster().integer(name, "SELECT count(*) FROM " + table);
  }
  long long tables() const {
    return postgres_cluster().integer(name, "SELECT count(*) FROM pg_tables WHERE schemaname = 'public'");
  }
};

RigOptions rig_on(const ScratchDirectory& dir, const Database& db, const std::string& time_scale = "0") {
  auto options = rig_options(dir.path().string(), {"--time-scale", time_scale});
  options.db = db.uri;
  return options;
}

TEST(PostgresqlProcessTest, AWholeSessionIsStoredInPostgresqlAndExportedFromIt) {
  ScratchDirectory dir;
  Database db;
  AcquisitionRig rig(rig_on(dir, db));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "PG1");
  ASSERT_NE(session, 0);
  ASSERT_EQ(wait_for_job(p, submit(p, session, {{"kind", "white"}}))["state"], "succeeded") << rig.logs();
  const auto sample = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(sample["state"], "succeeded") << sample << rig.logs();
  const auto measurement_id = sample["result"]["measurement_id"].get<long long>();
  const auto served = get_json(p, "/api/v1/measurements/" + std::to_string(measurement_id));
  EXPECT_EQ(db.count("measurements"), 2);
  EXPECT_EQ(db.count("fits"), 1);
  EXPECT_EQ(db.count("instruments"), 1);

  // Read beside the running daemon, then again after it stopped: the same records.
  for (int pass = 0; pass < 2; ++pass) {
    const auto exported = run_process(kSkinspec, {"export", "--db", db.uri, "--session", std::to_string(session)});
    ASSERT_EQ(exported.exit_status, 0) << exported.describe();
    const auto document = json::parse(exported.out);
    const auto text = document.dump();
    EXPECT_THAT(text, HasSubstr("PG1"));
    bool found = false;
    for (const auto& m : document["measurements"]) {
      if (m["id"] != measurement_id) continue;
      found = true;
      EXPECT_EQ(m["reflectance"]["values"], served["reflectance"]["values"]);
    }
    EXPECT_TRUE(found) << text.substr(0, 2000);
    if (pass == 0) {
      ASSERT_TRUE(rig.stop_daemon(SIGTERM).exited());
    }
  }

  rig.restart_daemon();
  ASSERT_NE(rig.port, 0) << rig.logs();
  EXPECT_EQ(get_json(rig.port, "/api/v1/measurements/" + std::to_string(measurement_id))["reflectance"],
            served["reflectance"]);
  EXPECT_EQ(get_json(rig.port, "/api/v1/sessions/" + std::to_string(session))["state"], "open");
}

// SIGKILL while a measurement job runs: the next start marks it failed (interrupted) and its
// session interrupted; every sample stored belongs to a job that succeeded, with its fit.
TEST(PostgresqlProcessTest, ADaemonKilledMidJobLeavesItInterruptedAndNothingHalfStored) {
  ScratchDirectory dir;
  Database db;
  AcquisitionRig rig(rig_on(dir, db, "0.05"));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "PG2");
  ASSERT_EQ(wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}))["state"], "succeeded");
  const auto accepted = submit(rig.port, session, {{"kind", "sample"}, {"count", 5}});
  ASSERT_TRUE(accepted["id"].is_number_integer()) << accepted;
  const auto job_id = accepted["id"].get<long long>();
  bool running = false;
  for (auto until = std::chrono::steady_clock::now() + 20s; !running && std::chrono::steady_clock::now() < until;) {
    running = get_json(rig.port, "/api/v1/jobs/" + std::to_string(job_id))["state"] == "running";
    if (!running) std::this_thread::sleep_for(20ms);
  }
  ASSERT_TRUE(running) << rig.logs();
  rig.stop_daemon(SIGKILL);
  rig.restart_daemon();
  ASSERT_NE(rig.port, 0) << rig.logs();
  const auto job = get_json(rig.port, "/api/v1/jobs/" + std::to_string(job_id));
  ASSERT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "interrupted") << job;
  EXPECT_EQ(get_json(rig.port, "/api/v1/sessions/" + std::to_string(session))["state"], "interrupted");
  EXPECT_EQ(db.count("measurements WHERE kind = 'sample'"), 0);
  EXPECT_EQ(db.count("fits"), 0);
}

ProcessResult skinspec(const std::vector<std::string>& args) { return run_process(kSkinspec, args); }

// A lab's SQLite file moved onto PostgreSQL and back: each copy exports byte for byte what the
// source exports; a second run writes nothing; a destination holding other records is refused
// untouched; the source file is never changed; skinspecd goes on from the copied ids.
TEST(PostgresqlProcessTest, MigrateDbCopiesALabsDatabaseWhole) {
  ScratchDirectory dir;
  long long session = 0;
  {
    AcquisitionRig rig(rig_options(dir.path().string(), 0.0));
    ASSERT_TRUE(rig.ready()) << rig.logs();
    session = new_session(rig.port, "M1");
    ASSERT_EQ(wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}))["state"], "succeeded");
    for (int i = 0; i < 2; ++i)
      ASSERT_EQ(wait_for_job(rig.port, submit(rig.port, session, {{"kind", "sample"}}))["state"], "succeeded");
    ASSERT_NE(new_session(rig.port, "M2"), 0);
  }
  const auto lab = dir.file("lab.db");
  const auto lab_bytes = file_bytes(lab);
  Database db;
  const auto copied = skinspec({"migrate-db", "--from", lab, "--to", db.uri});
  ASSERT_EQ(copied.exit_status, 0) << copied.describe();
  EXPECT_THAT(copied.out, HasSubstr("copied into"));
  EXPECT_THAT(copied.out, HasSubstr("measurements"));
  EXPECT_EQ(db.count("measurements"), 3);
  EXPECT_EQ(db.count("jobs"), 3);

  for (const auto* format : {"json", "csv"}) {
    const auto source = skinspec({"export", "--db", lab, "--format", format});
    const auto copy = skinspec({"export", "--db", db.uri, "--format", format});
    ASSERT_EQ(source.exit_status, 0) << source.describe();
    ASSERT_EQ(copy.exit_status, 0) << copy.describe();
    EXPECT_GT(source.out.size(), 1000u);
    EXPECT_TRUE(source.out == copy.out) << format;
  }

  const auto again = skinspec({"migrate-db", "--from", lab, "--to", db.uri});
  ASSERT_EQ(again.exit_status, 0) << again.describe();
  EXPECT_THAT(again.out, HasSubstr("nothing written"));
  EXPECT_EQ(db.count("measurements"), 3);

  const auto back = dir.file("back.db");
  ASSERT_EQ(skinspec({"migrate-db", "--from", db.uri, "--to", back}).exit_status, 0);
  const auto from_back = skinspec({"export", "--db", back});
  const auto from_lab = skinspec({"export", "--db", lab});
  ASSERT_EQ(from_back.exit_status, 0) << from_back.describe();
  ASSERT_EQ(from_lab.exit_status, 0) << from_lab.describe();
  EXPECT_TRUE(from_back.out == from_lab.out);

  ScratchDirectory other_dir;
  {
    AcquisitionRig rig(rig_options(other_dir.path().string(), 0.0));
    ASSERT_TRUE(rig.ready()) << rig.logs();
    ASSERT_NE(new_session(rig.port, "OTHER"), 0);
  }
  const auto refused = skinspec({"migrate-db", "--from", other_dir.file("lab.db"), "--to", db.uri});
  EXPECT_EQ(refused.exit_status, 2) << refused.describe();
  EXPECT_THAT(refused.err, HasSubstr("already holds records"));
  EXPECT_EQ(db.count("sessions"), 2);
  EXPECT_TRUE(file_bytes(lab) == lab_bytes);

  AcquisitionRig rig(rig_on(dir, db));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  EXPECT_EQ(new_session(rig.port, "M3"), session + 2);
}

// Each bad --db is refused before anything is served or written, naming the cause.
TEST(PostgresqlProcessTest, ABadDatabaseIsRefusedAtStartWithExitStatus2AndNothingWritten) {
  ScratchDirectory dir;
  Database empty;
  Database foreign;
  postgres_cluster().execute(foreign.name, "CREATE TABLE orders (id int); ALTER TABLE orders OWNER TO skinspec");
  Database readable;
  {
    AcquisitionRig rig(rig_on(dir, readable));
    ASSERT_TRUE(rig.ready()) << rig.logs();
    ASSERT_NE(new_session(rig.port, "PG3"), 0);
  }
  postgres_cluster().execute(readable.name, "GRANT SELECT ON ALL TABLES IN SCHEMA public TO skinspec_reader");
  const auto passwords = dir.file("pgpass");
  std::ofstream(passwords) << "*:*:*:skinspec_pw:not-the-password\n";
  std::filesystem::permissions(passwords, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);

  struct Case {
    std::string db;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"postgresql://skinspec@/" + empty.name + "?host=/nonexistent-socket-dir", "cannot reach the database server"},
      {postgres_cluster().uri(empty.name, "skinspec_pw"), "refused the password of role skinspec_pw"},
      {"postgresql://skinspec:secret@/" + empty.name, "PGPASSFILE"},
      {foreign.uri, "another application"},
      {postgres_cluster().uri(readable.name, "skinspec_reader"), "role skinspec_reader may not write"},
  };
  for (const auto& c : cases) {
    ProcessOptions options;
    options.timeout = 60s;
    options.environment = {"PGPASSFILE=" + passwords};
    const auto result = run_process(kSkinspecd, {"--listen", "127.0.0.1:0", "--db", c.db}, options);
    EXPECT_EQ(result.exit_status, 2) << c.db << "\n" << result.describe();
    EXPECT_THAT(result.out + result.err, HasSubstr(c.says)) << c.db;
    EXPECT_THAT(result.out + result.err, ::testing::Not(HasSubstr("secret"))) << c.db;
    EXPECT_THAT(result.out + result.err, ::testing::Not(HasSubstr("not-the-password"))) << c.db;
  }
  EXPECT_EQ(empty.tables(), 0);
  EXPECT_EQ(foreign.tables(), 1);
  EXPECT_EQ(readable.count("sessions"), 1);
}

}  // namespace
}  // namespace skinspec::testing
