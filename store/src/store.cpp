// Opening a store: checks made before anything is written, the writer lock, the connection
// settings, migrations and recovery; the read pool; closing.

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "codec.hpp"
#include "schema.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

using detail::Connection;
using detail::fail;
using detail::Transaction;
using Kind = StoreError::Kind;

namespace {

void set_busy_timeout(Connection& connection, std::chrono::milliseconds timeout) {
  sqlite3_busy_timeout(connection.handle(), static_cast<int>(timeout.count()));
}

}  // namespace

namespace detail {

void ReaderPool::configure(std::string path, std::chrono::milliseconds busy_timeout, int max_connections) {
  path_ = std::move(path);
  busy_timeout_ = busy_timeout;
  max_ = std::max(1, max_connections);
}

ReaderPool::Lease ReaderPool::acquire() {
  std::unique_lock lock(mutex_);
  returned_.wait(lock, [&] { return !idle_.empty() || open_ < max_; });
  if (!idle_.empty()) {
    auto connection = std::move(idle_.back());
    idle_.pop_back();
    return Lease(*this, std::move(connection));
  }
  ++open_;
  lock.unlock();
  try {
    auto connection = std::make_unique<Connection>(path_, SQLITE_OPEN_READONLY);
    set_busy_timeout(*connection, busy_timeout_);
    // A reader never writes the database file, not even a checkpoint when it closes.
    sqlite3_db_config(connection->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
    return Lease(*this, std::move(connection));
  } catch (...) {
    lock.lock();
    --open_;
    returned_.notify_one();
    throw;
  }
}

void ReaderPool::release(std::unique_ptr<Connection> connection) {
  {
    std::lock_guard lock(mutex_);
    idle_.push_back(std::move(connection));
  }
  returned_.notify_one();
}

void ReaderPool::close() {
  std::lock_guard lock(mutex_);
  idle_.clear();
  open_ = 0;
}

}  // namespace detail

namespace {

// What an existing file holds, read without changing a byte of it. Throws when it is not a
// skinspec database, is damaged, or comes from a newer schema.
int probe(const std::string& path, const OpenOptions& options) {
  std::unique_ptr<Connection> connection;
  try {
    connection = std::make_unique<Connection>(path, SQLITE_OPEN_READONLY);
    sqlite3_db_config(connection->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
    set_busy_timeout(*connection, options.busy_timeout);
    const auto application_id = connection->query_integer("PRAGMA application_id");
    const auto version = connection->query_integer("PRAGMA user_version");
    const auto objects = connection->query_integer("SELECT count(*) FROM sqlite_schema");
    if (application_id != detail::kApplicationId && (application_id != 0 || version != 0 || objects != 0)) {
      fail(Kind::corrupt, fmt::format("a SQLite database, but not a skinspec one (application_id {:#x}, "
                                      "user_version {}, {} schema objects)",
                                      application_id, version, objects));
    }
    if (version > detail::latest_schema_version()) {
      fail(Kind::newer_schema, fmt::format("written by a newer skinspec (schema version {}; this program knows "
                                           "versions up to {}); left unchanged",
                                           version, detail::latest_schema_version()));
    }
    if (options.check_integrity && objects != 0) {
      const auto verdict = connection->query_text("PRAGMA quick_check(1)");
      if (verdict != "ok") fail(Kind::corrupt, "damaged: " + verdict);
    }
    return static_cast<int>(version);
  } catch (const detail::Failure& failure) {
    const int primary = failure.error.sqlite_code & 0xff;
    if (primary == SQLITE_NOTADB) fail(Kind::corrupt, "not a SQLite database", failure.error.sqlite_code);
    if (primary == SQLITE_CORRUPT) fail(Kind::corrupt, "damaged: " + failure.error.message, failure.error.sqlite_code);
    throw;
  }
}

// Root may write any file, so the permission bits are checked as well as access(2): a file
// that nobody may write is treated as read-only for everyone.
bool writable(const std::string& path, const struct stat& info) {
  return (info.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) != 0 && ::access(path.c_str(), W_OK) == 0;
}

// Becomes the one writer of the database at `path`: an advisory lock on "<path>-lock", which
// the kernel releases if this process dies. A separate file, because closing any descriptor of
// the database file itself would cancel SQLite's own POSIX locks held by this process.
int take_writer_lock(const std::string& path) {
  const std::string lock_path = path + "-lock";
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int error = errno;
    fail(error == EACCES || error == EROFS ? Kind::read_only : Kind::io,
         fmt::format("cannot open the lock file {}: {}", lock_path, std::strerror(error)));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd);
    if (error == EWOULDBLOCK) fail(Kind::busy, "another program has it open for writing");
    fail(Kind::io, fmt::format("cannot lock {}: {}", lock_path, std::strerror(error)));
  }
  return fd;
}

void configure_writer(Connection& writer, const OpenOptions& options) {
  set_busy_timeout(writer, options.busy_timeout);
  if (sqlite3_db_readonly(writer.handle(), "main") == 1) fail(Kind::read_only, "the file is read-only");
  // WAL: readers never block the writer nor it them; FULL: a commit is on the disk (the WAL
  // synced) before it returns, so whatever was acknowledged survives a crash or power loss.
  const auto mode = writer.query_text("PRAGMA journal_mode = WAL");
  if (mode != "wal") fail(Kind::io, fmt::format("cannot use write-ahead logging (journal mode stays '{}')", mode));
  writer.execute("PRAGMA synchronous = FULL");
  writer.execute("PRAGMA foreign_keys = ON");
  if (options.max_pages > 0) writer.execute(fmt::format("PRAGMA max_page_count = {}", options.max_pages));
}

// Marks the sessions that were running when the last writer died as interrupted and fails
// the jobs it left queued or running. Such a job has stored nothing: a job's measurement is
// stored in the transaction that ends it (complete_measurement_job).
RecoveryReport recover(Connection& writer, RecoveryPolicy policy, Time now) {
  RecoveryReport report;
  Transaction transaction(writer, Transaction::Kind::write);
  {
    auto running = writer.prepare(
        policy == RecoveryPolicy::all_open_sessions
            ? "SELECT id FROM sessions WHERE state = 'open' ORDER BY id"
            : "SELECT DISTINCT s.id FROM sessions s JOIN jobs j ON j.session_id = s.id "
              "WHERE s.state = 'open' AND j.state IN ('queued', 'running') ORDER BY s.id");
    while (running.step()) report.interrupted_sessions.push_back(running.integer(0));
  }
  {
    auto active = writer.prepare("SELECT id FROM jobs WHERE state IN ('queued', 'running') ORDER BY id");
    while (active.step()) report.failed_jobs.push_back(active.integer(0));
  }
  const auto micros = detail::to_micros(now);
  const auto interrupted =
      detail::encode_job_error({JobErrorCode::interrupted, "the program running it stopped before it finished"});
  for (const Id id : report.interrupted_sessions) {
    writer.prepare("UPDATE sessions SET state = 'interrupted', updated_at = ?2, ended_at = ?2 WHERE id = ?1")
        .bind(id, micros)
        .run();
  }
  for (const Id id : report.failed_jobs) {
    writer.prepare("UPDATE jobs SET state = 'failed', error = ?2, finished_at = ?3 WHERE id = ?1")
        .bind(id, interrupted, micros)
        .run();
  }
  transaction.commit();
  return report;
}

void open_read_write(Store::Impl& impl) {
  const auto& path = impl.path;
  struct stat info {};
  const bool exists = ::stat(path.c_str(), &info) == 0;
  if (exists && !S_ISREG(info.st_mode)) fail(Kind::invalid_argument, "not a regular file");
  if (exists && !writable(path, info)) fail(Kind::read_only, "the file is read-only");
  if (exists && info.st_size > 0) probe(path, impl.options);

  impl.lock_fd = take_writer_lock(path);
  impl.writer = std::make_unique<Connection>(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  // Checked again now that this is the only writer (the file may have changed since the probe).
  if (impl.writer->query_integer("PRAGMA user_version") > detail::latest_schema_version())
    fail(Kind::newer_schema, "written by a newer skinspec; left unchanged");
  configure_writer(*impl.writer, impl.options);
  detail::migrate(*impl.writer, detail::latest_schema_version());
  impl.version = detail::latest_schema_version();
  impl.recovery = recover(*impl.writer, impl.options.recovery, impl.now());
}

void open_read_only(Store::Impl& impl) {
  struct stat info {};
  if (::stat(impl.path.c_str(), &info) != 0) fail(Kind::not_found, "no database file there");
  if (!S_ISREG(info.st_mode)) fail(Kind::invalid_argument, "not a regular file");
  if (info.st_size == 0) fail(Kind::corrupt, "an empty file, not a skinspec database");
  impl.version = probe(impl.path, impl.options);
  if (impl.version < detail::latest_schema_version()) {
    fail(Kind::older_schema, fmt::format("schema version {} needs migrating to {}; open it once read-write",
                                         impl.version, detail::latest_schema_version()));
  }
}

}  // namespace

Store::Impl::~Impl() {
  readers.close();
  writer.reset();  // the last connection out checkpoints the WAL into the database
  if (lock_fd >= 0) ::close(lock_fd);
}

Time Store::Impl::now() const {
  if (options.clock) return options.clock();
  return std::chrono::floor<std::chrono::microseconds>(std::chrono::system_clock::now());
}

Result<Store> Store::open(const std::string& path, const OpenOptions& options) {
  return detail::guarded(fmt::format("opening the database {}", path), [&] {
    if (path.empty() || path == ":memory:" || path.starts_with("file:"))
      fail(Kind::invalid_argument, "the database must be a file path");
    auto impl = std::make_unique<Impl>();
    impl->path = path;
    impl->options = options;
    if (options.read_only) {
      open_read_only(*impl);
    } else {
      open_read_write(*impl);
    }
    impl->readers.configure(path, options.busy_timeout, options.max_readers);
    return Store(std::move(impl));
  });
}

Store::Store(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

const std::string& Store::path() const { return impl_->path; }
int Store::schema_version() const { return impl_->version; }
const RecoveryReport& Store::recovery() const { return impl_->recovery; }

int current_schema_version() { return detail::latest_schema_version(); }

Result<void> create_database_at_version(const std::string& path, int version) {
  return detail::guarded(fmt::format("creating a version-{} database at {}", version, path), [&] {
    if (version < 1 || version > detail::latest_schema_version())
      fail(Kind::invalid_argument, fmt::format("versions are 1 to {}", detail::latest_schema_version()));
    struct stat info {};
    if (::stat(path.c_str(), &info) == 0) fail(Kind::conflict, "the file exists");
    Connection writer(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    OpenOptions options;
    configure_writer(writer, options);
    detail::migrate(writer, version);
  });
}

}  // namespace skinspec::store
