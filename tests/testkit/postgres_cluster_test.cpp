// The throwaway PostgreSQL cluster the store's tests run against: it starts with its roles,
// makes databases, survives a stop as after a crash, runs the server as an unprivileged user
// when the test is root, and is stopped and removed even when its test program is killed.

#include <gtest/gtest.h>
#include <pwd.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// Whether process `pid` is gone (a zombie nobody reaped counts as gone: it runs nothing).
bool process_gone(pid_t pid) {
  const auto stat = process_stat(pid);
  return !stat || stat->state == 'Z';
}

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(PostgresClusterTest, StartsWithItsRolesAndMakesSeparateDatabasesOwnedBySkinspec) {
  auto& cluster = postgres_cluster();
  const auto first = cluster.create_database();
  const auto second = cluster.create_database();
  ASSERT_NE(first, second);

  auto db = raw_database(cluster.uri(first));
  EXPECT_EQ(db->backend(), store::Backend::postgresql);
  db->execute("CREATE TABLE t (x bigint); INSERT INTO t VALUES (7)");
  EXPECT_EQ(db->integer("SELECT x FROM t"), 7);
  EXPECT_EQ(db->text("SELECT current_user"), "skinspec");
  EXPECT_EQ(cluster.text("postgres", "SELECT pg_get_userbyid(datdba) FROM pg_database WHERE datname = '" + first + "'"),
            "skinspec");
  EXPECT_EQ(cluster.integer(second, "SELECT count(*) FROM pg_tables WHERE tablename = 't'"), 0);
  EXPECT_EQ(cluster.text(first,
                         "SELECT string_agg(rolname, ',' ORDER BY rolname) FROM pg_roles WHERE rolname "
                         "LIKE 'skinspec%' OR rolname = 'admin'"),
            "admin,skinspec,skinspec_pw,skinspec_reader");
  EXPECT_EQ(cluster.text("postgres", "SHOW fsync"), "off");
  EXPECT_EQ(cluster.text("postgres", "SHOW synchronous_commit"), "on");
  EXPECT_EQ(cluster.text("postgres", "SHOW listen_addresses"), "");

  // Root never runs the server: PostgreSQL refuses to, so it runs as nobody.
  struct stat server{};
  ASSERT_EQ(::stat(("/proc/" + std::to_string(cluster.server_pid())).c_str(), &server), 0);
  const passwd* nobody = ::getpwnam("nobody");
  ASSERT_NE(nobody, nullptr);
  EXPECT_EQ(server.st_uid, ::geteuid() == 0 ? nobody->pw_uid : ::geteuid());
}

TEST(PostgresClusterTest, TheReaderMayNotCreateTablesAndThePasswordRoleNeedsItsPassword) {
  auto& cluster = postgres_cluster();
  const auto database = cluster.create_database();
  EXPECT_NE(error_of([&] {
              raw_database(cluster.uri(database, "skinspec_reader"))->execute("CREATE TABLE r (x int)");
            }).find("permission denied"),
            std::string::npos);

  ScratchDirectory scratch;
  const auto passwords = scratch.file("pgpass");
  const auto with_password = [&](const std::string& password) {
    std::ofstream(passwords) << "*:*:*:skinspec_pw:" << password << "\n";
    fs::permissions(passwords, fs::perms::owner_read | fs::perms::owner_write);
    ::setenv("PGPASSFILE", passwords.c_str(), 1);
    return error_of([&] { raw_database(cluster.uri(database, "skinspec_pw"))->text("SELECT 1"); });
  };
  EXPECT_EQ(with_password("right"), "");
  EXPECT_NE(with_password("wrong").find("password authentication failed"), std::string::npos);
  ::setenv("PGPASSFILE", scratch.file("none").c_str(), 1);
  EXPECT_NE(error_of([&] {
              raw_database(cluster.uri(database, "skinspec_pw"))->text("SELECT 1");
            }).find("no password supplied"),
            std::string::npos);
  ::unsetenv("PGPASSFILE");
}

TEST(PostgresClusterTest, AServerStoppedAsAfterACrashStartsAgainWithWhatWasCommitted) {
  auto& cluster = postgres_cluster();
  const auto database = cluster.create_database();
  raw_database(cluster.uri(database))->execute("CREATE TABLE t (x bigint); INSERT INTO t VALUES (42)");

  cluster.stop("immediate");
  EXPECT_FALSE(cluster.running());
  EXPECT_NE(error_of([&] { raw_database(cluster.uri(database)); }), "");

  cluster.start();
  EXPECT_EQ(raw_database(cluster.uri(database))->integer("SELECT x FROM t"), 42) << cluster.log_tail();
}

TEST(PostgresClusterTest, TheGuardianStopsAndRemovesTheClusterOfAProgramKilledWithSigkill) {
  BackgroundProcess holder(SKINSPEC_TEST_BIN_DIR "/postgres_cluster_holder", {});
  ASSERT_TRUE(holder.started()) << holder.start_error();
  const auto directory = holder.wait_for_stdout_line("directory ", 60s);
  const auto server = holder.wait_for_stdout_line("server ", 5s);
  ASSERT_TRUE(directory && server) << holder.err();
  const fs::path dir = directory->substr(10);
  const pid_t pid = std::stoi(server->substr(7));
  ASSERT_TRUE(fs::exists(dir / "data" / "postmaster.pid"));
  ASSERT_FALSE(process_gone(pid));

  holder.send_signal(SIGKILL);
  holder.wait(10s);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while ((fs::exists(dir) || !process_gone(pid)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(20ms);
  EXPECT_FALSE(fs::exists(dir));
  EXPECT_TRUE(process_gone(pid));
}

}  // namespace
}  // namespace skinspec::testing
