#include "skinspec/testkit/postgres_cluster.hpp"

#include <fcntl.h>
#include <grp.h>
#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <deque>
#include <fstream>
#include <optional>
#include <stdexcept>

#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/raw_database.hpp"

extern char** environ;

namespace skinspec::testing {

namespace fs = std::filesystem;

namespace {

// Raised when what the template holds (its settings, its roles) changes, so that a build tree
// never uses a template made by an older harness.
constexpr std::string_view kTemplateFormat = "1";

// Settings every cluster shares, written into the template's postgresql.conf.
constexpr std::string_view kTemplateSettings = R"(
listen_addresses = ''
unix_socket_permissions = 0777
shared_buffers = 16MB
max_connections = 60
log_min_messages = warning
)";

constexpr std::string_view kTemplateHba =
    "local all skinspec_pw scram-sha-256\n"
    "local all all trust\n";

constexpr std::string_view kTemplateRoles =
    "CREATE ROLE skinspec LOGIN; CREATE ROLE skinspec_reader LOGIN; "
    "CREATE ROLE skinspec_pw LOGIN PASSWORD 'right'";

[[noreturn]] void fail(const std::string& message) { throw std::runtime_error("PostgreSQL test cluster: " + message); }

std::string program(const std::string& name) { return std::string(SKINSPEC_TEST_PG_BINDIR) + "/" + name; }

// Whom initdb and the server run as: this user, or `nobody` when this is root.
struct ServerUser {
  bool switched = false;
  uid_t uid = 0;
  gid_t gid = 0;
};

const ServerUser& server_user() {
  static const ServerUser user = [] {
    if (::geteuid() != 0) return ServerUser{false, ::geteuid(), ::getegid()};
    const passwd* nobody = ::getpwnam("nobody");
    const group* nogroup = ::getgrnam("nogroup");
    if (!nobody || !nogroup) fail("running as root needs the user nobody and the group nogroup");
    return ServerUser{true, nobody->pw_uid, nogroup->gr_gid};
  }();
  return user;
}

// `program` with `args` as the server's user: through setpriv when this is root.
std::vector<std::string> as_server_user(const std::string& name, const std::vector<std::string>& args) {
  std::vector<std::string> command;
  const auto& user = server_user();
  if (user.switched) {
    command = {"/usr/bin/setpriv", "--reuid=" + std::to_string(user.uid), "--regid=" + std::to_string(user.gid),
               "--clear-groups", "--"};
  }
  command.push_back(program(name));
  command.insert(command.end(), args.begin(), args.end());
  return command;
}

void run_as_server_user(const std::string& name, const std::vector<std::string>& args) {
  const auto command = as_server_user(name, args);
  ProcessOptions options;
  options.timeout = std::chrono::seconds(60);
  const auto result = run_process(command.front(), {command.begin() + 1, command.end()}, options);
  if (!result.exited() || result.exit_status != 0) fail(name + " failed: " + result.describe());
}

void hand_to_server_user(const fs::path& root) {
  const auto& user = server_user();
  if (!user.switched) return;
  if (::lchown(root.c_str(), user.uid, user.gid) != 0) fail("cannot chown " + root.string());
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (::lchown(entry.path().c_str(), user.uid, user.gid) != 0) fail("cannot chown " + entry.path().string());
}

bool usable_base(const fs::path& base) {
  struct stat info{};
  // Others must be able to pass through it when the server runs as nobody.
  return ::stat(base.c_str(), &info) == 0 && S_ISDIR(info.st_mode) && ::access(base.c_str(), W_OK | X_OK) == 0 &&
         (!server_user().switched || (info.st_mode & S_IXOTH) != 0);
}

fs::path base_for(const ClusterSettings& settings) {
  if (!settings.base.empty()) return settings.base;
  if (!settings.durable && usable_base("/dev/shm")) return "/dev/shm";
  const char* tmpdir = std::getenv("TMPDIR");
  if (tmpdir && *tmpdir && usable_base(tmpdir)) return tmpdir;
  return "/tmp";
}

// A new directory (mode 0700) owned by the server's user.
fs::path make_directory(const fs::path& base, const std::string& prefix) {
  std::string pattern = (base / (prefix + "XXXXXX")).string();
  if (!::mkdtemp(pattern.data())) fail("cannot make a directory in " + base.string() + ": " + std::strerror(errno));
  hand_to_server_user(pattern);
  return pattern;
}

void append(const fs::path& file, std::string_view text) {
  std::ofstream out(file, std::ios::app | std::ios::binary);
  out << text;
  if (!out.flush()) fail("cannot write " + file.string());
}

// Stops the server of `data` and removes `directory` when the write end of its standard
// input closes: when the process that started it ends, even by SIGKILL. Its own session, so
// that a signal to the test's process group leaves it running to clean up.
class Guardian {
 public:
  Guardian(const fs::path& directory, const fs::path& data) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) fail("cannot make a pipe for the guardian");
    std::vector<std::string> args = {"/bin/sh", "-c",
                                     "cat >/dev/null; dir=$1; shift; \"$@\" >/dev/null 2>&1; rm -rf \"$dir\"",
                                     "guardian", directory.string()};
    for (auto& arg : as_server_user("pg_ctl", {"-D", data.string(), "-m", "immediate", "-w", "stop"}))
      args.push_back(std::move(arg));
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[0], 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigmask(&attributes, &none);
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSID | POSIX_SPAWN_SETSIGMASK);
    const int spawned = ::posix_spawn(&pid_, "/bin/sh", &actions, &attributes, argv.data(), environ);
    posix_spawnattr_destroy(&attributes);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[0]);
    if (spawned != 0) {
      ::close(fds[1]);
      fail(std::string("cannot start the guardian: ") + std::strerror(spawned));
    }
    pipe_ = fds[1];
  }
  ~Guardian() { release(); }
  Guardian(const Guardian&) = delete;
  Guardian& operator=(const Guardian&) = delete;

  // Lets it do its work now and waits for it.
  void release() {
    if (pipe_ < 0) return;
    ::close(pipe_);
    pipe_ = -1;
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }

 private:
  pid_t pid_ = 0;
  int pipe_ = -1;
};

// `options` for the server, such as "-k SOCKET_DIR" (pg_ctl passes them through a shell: the
// directories are mkdtemp's names, with no character a shell would read).
void start_server(const fs::path& data, const fs::path& log, const std::string& options) {
  run_as_server_user("pg_ctl", {"-D", data.string(), "-l", log.string(), "-o", options, "-w", "-t", "60", "start"});
}

void stop_server(const fs::path& data, std::string_view mode) {
  run_as_server_user("pg_ctl", {"-D", data.string(), "-m", std::string(mode), "-w", "-t", "60", "stop"});
}

std::string admin_uri(const fs::path& socket_dir, const std::string& database) {
  return "postgresql://admin@/" + database + "?host=" + socket_dir.string();
}

// The WAL's segment size of a template, in MB: 1 for tests, whose clusters are copied for each
// test program and never wait for the disk; the server's default of 16 for durable clusters, as
// a lab's server has it. (A fresh cluster makes each segment new, where a server that has run a
// while reuses old ones; with 1 MB segments it would make them sixteen times as often.)
int wal_segment_mb(bool durable) { return durable ? 16 : 1; }

// initdb into a directory of its own, the settings, the roles; then moved into the build tree.
void make_template(const fs::path& destination, int segment_mb) {
  const auto work = make_directory(base_for({}), "skinspec-pg-template-");
  const auto data = work / "data";
  Guardian guardian(work, data);
  run_as_server_user("initdb", {"-D", data.string(), "-U", "admin", "--auth=trust", "--no-sync", "--no-instructions",
                                "-E", "UTF8", "--locale=C.UTF-8", "--wal-segsize=" + std::to_string(segment_mb)});
  append(data / "postgresql.conf", kTemplateSettings);
  {
    std::ofstream hba(data / "pg_hba.conf", std::ios::trunc | std::ios::binary);
    hba << kTemplateHba;
  }
  start_server(data, work / "log", "-k " + work.string() + " -c fsync=off");
  raw_database(admin_uri(work, "postgres"))->execute(std::string(kTemplateRoles));
  stop_server(data, "fast");
  fs::remove(data / "postmaster.opts");
  const auto staging = destination.string() + ".staging";
  fs::remove_all(staging);
  fs::copy(data, staging, fs::copy_options::recursive);
  fs::rename(staging, destination);
}

// The template of this build tree, made by the first test program that needs it while the
// others wait on its lock.
fs::path template_directory(int segment_mb) {
  const fs::path root = SKINSPEC_TEST_PG_TEMPLATE_ROOT;
  const auto destination = root / ("template-" + std::string(SKINSPEC_TEST_PG_VERSION) + "-" +
                                   std::string(kTemplateFormat) + "-wal" + std::to_string(segment_mb) + "mb");
  if (fs::exists(destination)) return destination;
  fs::create_directories(root);
  const auto lock_path = root / "template.lock";
  const int lock = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock < 0) fail("cannot open " + lock_path.string());
  while (::flock(lock, LOCK_EX) != 0 && errno == EINTR) {
  }
  try {
    if (!fs::exists(destination)) make_template(destination, segment_mb);
  } catch (...) {
    ::close(lock);
    throw;
  }
  ::close(lock);
  return destination;
}

std::string tail_of(const std::string& text, std::size_t lines) {
  std::size_t start = text.size();
  for (std::size_t found = 0; found <= lines && start > 0;) {
    start = text.rfind('\n', start - 1);
    if (start == std::string::npos) return text;
    ++found;
  }
  return text.substr(start + 1);
}

}  // namespace

struct PostgresCluster::Parts {
  std::optional<Guardian> guardian;
};

PostgresCluster::PostgresCluster(ClusterSettings settings)
    : settings_(std::move(settings)), owner_(::getpid()), parts_(std::make_unique<Parts>()) {
  const auto source = template_directory(wal_segment_mb(settings_.durable));
  directory_ = make_directory(base_for(settings_), "skinspec-pg-");
  try {
    parts_->guardian.emplace(directory_, data());
    fs::copy(source, data(), fs::copy_options::recursive);
    hand_to_server_user(directory_);
    start();
  } catch (...) {
    parts_->guardian.reset();  // stops whatever started and removes the directory
    throw;
  }
}

PostgresCluster::~PostgresCluster() {
  if (::getpid() != owner_) return;  // a forked child's copy: the cluster is its parent's
  // The guardian stops the server as after a crash and removes everything: nothing of it is
  // kept, so nothing needs a clean shutdown.
  parts_->guardian.reset();
}

fs::path PostgresCluster::data() const { return directory_ / "data"; }

pid_t PostgresCluster::server_pid() const {
  std::ifstream in(data() / "postmaster.pid");
  long pid = 0;
  if (!(in >> pid)) return 0;
  return static_cast<pid_t>(pid);
}

std::string PostgresCluster::create_database(const std::string& prefix) {
  for (const char c : prefix)
    if (!((c >= 'a' && c <= 'z') || c == '_')) fail("a database prefix is lower-case letters and '_'");
  const auto name = prefix + std::to_string(++databases_);
  execute("postgres", "CREATE DATABASE " + name + " OWNER skinspec");
  return name;
}

std::string PostgresCluster::program(const std::string& name) { return skinspec::testing::program(name); }

std::string PostgresCluster::uri(const std::string& database, const std::string& role) const {
  return "postgresql://" + role + "@/" + database + "?host=" + directory_.string();
}

void PostgresCluster::execute(const std::string& database, const std::string& sql) const {
  raw_database(admin_uri(directory_, database))->execute(sql);
}

std::string PostgresCluster::text(const std::string& database, const std::string& sql) const {
  return raw_database(admin_uri(directory_, database))->text(sql);
}

long long PostgresCluster::integer(const std::string& database, const std::string& sql) const {
  return raw_database(admin_uri(directory_, database))->integer(sql);
}

void PostgresCluster::stop(std::string_view mode) {
  stop_server(data(), mode);
  running_ = false;
}

void PostgresCluster::start() {
  // Durable: a checkpoint, after which each page is written whole again, comes only after 4 GB
  // of WAL (one comes at about half of max_wal_size), more than a run of the benchmarks writes;
  // and no autovacuum, whose workers would take the processor from a run (and be counted as its
  // server's time) at moments of their own.
  const std::string durability = settings_.durable ? " -c fsync=on -c full_page_writes=on -c max_wal_size=8GB "
                                                     "-c checkpoint_timeout=15min -c autovacuum=off"
                                                   : " -c fsync=off -c full_page_writes=off";
  start_server(data(), directory_ / "log", "-k " + directory_.string() + durability + " -c synchronous_commit=on");
  running_ = true;
}

std::string PostgresCluster::log_tail() const {
  std::ifstream in(directory_ / "log", std::ios::binary);
  return tail_of(std::string((std::istreambuf_iterator<char>(in)), {}), 20);
}

std::filesystem::path postgres_program(const std::string& name) { return program(name); }

PostgresCluster& postgres_cluster() {
  static PostgresCluster cluster;
  return cluster;
}

}  // namespace skinspec::testing
