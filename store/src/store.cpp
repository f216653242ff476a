// Opening a store: checks made before anything is written, the writer lock, the connection
// settings, migrations and recovery; the read pool; closing.

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>

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

void ReaderPool::configure(std::string filename, int flags, std::chrono::milliseconds busy_timeout,
                           int max_connections) {
  filename_ = std::move(filename);
  flags_ = flags;
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
    auto connection = std::make_unique<Connection>(filename_, flags_);
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

FileIdentity FileIdentity::of(const struct stat& info) {
  return {info.st_dev, info.st_ino, info.st_size, info.st_mtim, info.st_ctim};
}

bool FileIdentity::operator==(const FileIdentity& other) const {
  const auto same_time = [](const timespec& a, const timespec& b) {
    return a.tv_sec == b.tv_sec && a.tv_nsec == b.tv_nsec;
  };
  return device == other.device && inode == other.inode && size == other.size && same_time(modified, other.modified) &&
         same_time(changed, other.changed);
}

}  // namespace detail

namespace {

using detail::FileIdentity;

// How a connection that only reads reaches the file without creating anything beside it.
// SQLite opens (and leaves behind) PATH-wal and PATH-shm for any reader of a WAL database, even
// a read-only one. While they exist a writer is live (or died): read through them, so that
// what it committed is seen. Without them the file holds every committed page; it is read as
// immutable, with no locks and no -shm, and the Store checks that it stays unchanged.
struct ReadAccess {
  std::string filename;
  int flags = SQLITE_OPEN_READONLY;
  bool immutable = false;
};

// A URI for sqlite3_open_v2: every byte outside a safe set percent-encoded, so that a '?', '#'
// or '%' in the path stays part of it.
std::string file_uri(const std::string& path, std::string_view query) {
  std::error_code failed;  // no working directory: a relative path stays relative
  auto absolute = std::filesystem::absolute(path, failed).string();
  if (absolute.empty()) absolute = path;
  std::string uri = absolute.starts_with('/') ? "file://" : "file:";
  for (const char c : absolute) {
    const auto byte = static_cast<unsigned char>(c);
    if (std::isalnum(byte) || std::strchr("/._-~", c) != nullptr) {
      uri += c;
    } else {
      uri += fmt::format("%{:02X}", byte);
    }
  }
  return uri + "?" + std::string(query);
}

ReadAccess read_access(const std::string& path) {
  struct stat wal {};
  if (::stat((path + "-wal").c_str(), &wal) == 0) return {path, SQLITE_OPEN_READONLY, false};
  return {file_uri(path, "immutable=1"), SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, true};
}

// SQLite reads a file shorter than its header as an empty database, which a writer would then
// fill: so a file that does not start with SQLite's magic string is refused here.
void require_sqlite_header(Connection& connection) {
  constexpr std::string_view kMagic{"SQLite format 3\0", 16};
  sqlite3_file* file = nullptr;
  if (sqlite3_file_control(connection.handle(), "main", SQLITE_FCNTL_FILE_POINTER, &file) != SQLITE_OK ||
      file == nullptr || file->pMethods == nullptr)
    return;  // nothing to read it through: SQLite's own checks follow
  // Through SQLite's own file handle: closing a descriptor of our own would drop the POSIX
  // locks SQLite holds on the file for this process.
  std::array<char, kMagic.size()> header{};
  const int rc = file->pMethods->xRead(file, header.data(), static_cast<int>(header.size()), 0);
  if (rc == SQLITE_IOERR_SHORT_READ || (rc == SQLITE_OK && std::string_view(header.data(), header.size()) != kMagic))
    fail(Kind::corrupt, "not a SQLite database");
  if (rc != SQLITE_OK) fail(Kind::io, fmt::format("cannot read its header (SQLite error {})", rc), rc);
}

// quick_check reports on several lines ("*** in database main ***", then the damage).
std::string one_line(std::string text) {
  std::ranges::replace(text, '\n', ' ');
  return text;
}

// What an existing file holds, read without changing a byte of it or creating a file beside
// it. Throws when it is not a skinspec database, is damaged, or comes from a newer schema.
int probe(const ReadAccess& access, const OpenOptions& options) {
  std::unique_ptr<Connection> connection;
  try {
    connection = std::make_unique<Connection>(access.filename, access.flags);
    sqlite3_db_config(connection->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
    set_busy_timeout(*connection, options.busy_timeout);
    require_sqlite_header(*connection);
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
      if (verdict != "ok") fail(Kind::corrupt, "damaged: " + one_line(verdict));
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
    auto running = writer.prepare(policy == RecoveryPolicy::all_open_sessions
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
  if (exists && info.st_size > 0) probe(read_access(path), impl.options);

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
  // Taken before looking for a -wal: a writer that starts in between changes the file after it.
  const auto identity = FileIdentity::of(info);
  const auto access = read_access(impl.path);
  if (access.immutable) impl.frozen = identity;
  try {
    impl.version = probe(access, impl.options);
  } catch (const detail::Failure&) {
    impl.check_still_frozen();  // a writer that started meanwhile explains whatever the probe found
    throw;
  }
  impl.check_still_frozen();
  if (impl.version == 0) fail(Kind::corrupt, "an empty SQLite database, not a skinspec one");
  if (impl.version < detail::latest_schema_version()) {
    fail(Kind::older_schema,
         fmt::format("schema version {} is older than this program's {}; it is migrated when skinspecd "
                     "next opens it, and left unchanged here",
                     impl.version, detail::latest_schema_version()));
  }
  impl.readers.configure(access.filename, access.flags, impl.options.busy_timeout, impl.options.max_readers);
}

}  // namespace

Store::Impl::~Impl() {
  readers.close();
  writer.reset();  // the last connection out checkpoints the WAL into the database
  if (lock_fd >= 0) ::close(lock_fd);
}

void Store::Impl::check_still_frozen() const {
  if (!frozen) return;
  struct stat info {};
  if (::stat(path.c_str(), &info) == 0 && FileIdentity::of(info) == *frozen) return;
  fail(Kind::busy, "the file changed while it was read (a program started writing it); read it again");
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
    if (options.mode == OpenMode::read_only) {
      open_read_only(*impl);
    } else {
      open_read_write(*impl);
      impl->readers.configure(path, SQLITE_OPEN_READONLY, options.busy_timeout, options.max_readers);
    }
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
