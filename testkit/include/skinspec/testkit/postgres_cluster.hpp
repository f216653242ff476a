#pragma once
// A throwaway PostgreSQL server for tests: a cluster of its own in a temporary directory,
// reached only through a Unix socket in that directory (no TCP port, so test programs running
// side by side never meet), stopped and removed when the test program ends, however it ends.
//
// The cluster is a copy of a template made once per build tree by initdb (one with 1 MB WAL
// segments for tests, one with the server's default 16 MB for durable clusters). When the test runs
// as root, initdb and the server run as `nobody` (PostgreSQL refuses to run as root). Roles:
// `admin` (superuser, what the helpers below connect as), `skinspec` (owns the databases
// create_database makes), `skinspec_reader` (may log in, owns nothing) and `skinspec_pw`
// (password "right", asked for by the server). Every other role logs in without a password.

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace skinspec::testing {

struct ClusterSettings {
  // false (tests): fsync and full-page writes off, so a commit does not wait for the disk
  // (synchronous_commit stays on; a server stopped with "immediate" still replays its WAL).
  // true (benchmarks): every commit is flushed, the data directory on a real disk, the WAL in
  // 16 MB segments as a lab's server has them, no checkpoint before 4 GB of it, and no autovacuum.
  bool durable = false;
  // Where the temporary directory goes; empty: /dev/shm when it is usable and !durable, else
  // $TMPDIR or /tmp.
  std::filesystem::path base;
};

class PostgresCluster {
 public:
  // Copies the template, starts the server and its guardian, or throws std::runtime_error.
  explicit PostgresCluster(ClusterSettings settings = {});
  // Stops the server ("fast") and removes the directory.
  ~PostgresCluster();
  PostgresCluster(const PostgresCluster&) = delete;
  PostgresCluster& operator=(const PostgresCluster&) = delete;

  const std::filesystem::path& directory() const { return directory_; }
  const std::filesystem::path& socket_dir() const { return directory_; }
  // The server's socket in socket_dir(), as libpq names it for the default port.
  std::filesystem::path socket() const { return directory_ / ".s.PGSQL.5432"; }
  // The server's process id while it runs (from postmaster.pid), else 0.
  pid_t server_pid() const;

  // A PostgreSQL program of the cluster's version (pg_dump, pg_restore, psql).
  static std::string program(const std::string& name);
  // A fresh empty database owned by `skinspec`, named `prefix` and a number; returns its name.
  std::string create_database(const std::string& prefix = "t");
  // "postgresql://ROLE@/DATABASE?host=SOCKET_DIR"
  std::string uri(const std::string& database, const std::string& role = "skinspec") const;

  // As the superuser `admin`, outside any store; each throws std::runtime_error with the
  // server's message.
  void execute(const std::string& database, const std::string& sql) const;
  std::string text(const std::string& database, const std::string& sql) const;
  long long integer(const std::string& database, const std::string& sql) const;

  // "fast", or "immediate": as after a crash (the next start replays the WAL).
  void stop(std::string_view mode = "fast");
  // The same directory and socket again.
  void start();
  bool running() const { return running_; }

  // The last lines of the server's log, for assertion messages.
  std::string log_tail() const;

 private:
  struct Parts;
  std::filesystem::path data() const;

  ClusterSettings settings_;
  std::filesystem::path directory_;
  pid_t owner_ = 0;  // the process that made it: a forked child never stops it
  std::unique_ptr<Parts> parts_;
  bool running_ = false;
  int databases_ = 0;
};

// The path of a program of the PostgreSQL installation the clusters run (such as "pgbench").
std::filesystem::path postgres_program(const std::string& name);

// The one cluster of this test program, started on first use (a test that never touches
// PostgreSQL pays nothing) and stopped at exit.
PostgresCluster& postgres_cluster();

}  // namespace skinspec::testing
