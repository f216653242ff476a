// Opening a SQLite file: the checks made before anything is written, the writer lock, the
// connection settings, migrations and recovery; the read pool.

#include "sqlite/open.hpp"

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

#include "recovery.hpp"
#include "sqlite/engine.hpp"
#include "sqlite/migrations.hpp"
#include "store_impl.hpp"

namespace skinspec::store::sqlite {

using detail::fail;
using Kind = StoreError::Kind;

namespace {

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
  struct stat wal{};
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
  if (rc != SQLITE_OK)
    throw detail::Failure{{Kind::io, fmt::format("cannot read its header (SQLite error {})", rc), rc}};
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
    sqlite3_busy_timeout(connection->handle(), static_cast<int>(options.busy_timeout.count()));
    require_sqlite_header(*connection);
    const auto application_id = connection->query_integer("PRAGMA application_id");
    const auto version = connection->query_integer("PRAGMA user_version");
    const auto objects = connection->query_integer("SELECT count(*) FROM sqlite_schema");
    if (application_id != kApplicationId && (application_id != 0 || version != 0 || objects != 0)) {
      fail(Kind::corrupt, fmt::format("a SQLite database, but not a skinspec one (application_id {:#x}, "
                                      "user_version {}, {} schema objects)",
                                      application_id, version, objects));
    }
    detail::refuse_newer_schema(static_cast<int>(version));
    if (options.check_integrity && objects != 0) {
      const auto verdict = connection->query_text("PRAGMA quick_check(1)");
      if (verdict != "ok") fail(Kind::corrupt, "damaged: " + one_line(verdict));
    }
    return static_cast<int>(version);
  } catch (const detail::Failure& failure) {
    const int primary = failure.error.sqlite_code & 0xff;
    if (primary == SQLITE_NOTADB) sqlite::fail(failure.error.sqlite_code, "not a SQLite database");
    if (primary == SQLITE_CORRUPT) sqlite::fail(failure.error.sqlite_code, "damaged: " + failure.error.message);
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
  sqlite3_busy_timeout(writer.handle(), static_cast<int>(options.busy_timeout.count()));
  if (sqlite3_db_readonly(writer.handle(), "main") == 1) fail(Kind::read_only, "the file is read-only");
  // WAL: readers never block the writer nor it them; FULL: a commit is on the disk (the WAL
  // synced) before it returns, so whatever was acknowledged survives a crash or power loss.
  const auto mode = writer.query_text("PRAGMA journal_mode = WAL");
  if (mode != "wal") fail(Kind::io, fmt::format("cannot use write-ahead logging (journal mode stays '{}')", mode));
  writer.execute("PRAGMA synchronous = FULL");
  writer.execute("PRAGMA foreign_keys = ON");
  // Room for a batch of an import (OpenOptions::import_batch, a few MB) and the indexes' pages it
  // passes through, so that a transaction's pages are written to the log once, at its commit,
  // and not spilled into it before (SQLite's default is 2 MB).
  writer.execute("PRAGMA cache_size = -16384");
  if (options.max_pages > 0) writer.execute(fmt::format("PRAGMA max_page_count = {}", options.max_pages));
}

void open_read_write(Store::Impl& impl, SqliteEngine& engine) {
  const auto& path = impl.path;
  struct stat info{};
  const bool exists = ::stat(path.c_str(), &info) == 0;
  if (!exists && !impl.options.create_missing) fail(Kind::not_found, "no database file there");
  if (exists && !S_ISREG(info.st_mode)) fail(Kind::invalid_argument, "not a regular file");
  if (exists && !writable(path, info)) fail(Kind::read_only, "the file is read-only");
  if (exists && info.st_size > 0) probe(read_access(path), impl.options);

  const int lock_fd = take_writer_lock(path);
  try {
    engine.set_writer(std::make_unique<Connection>(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE), lock_fd);
  } catch (...) {
    ::close(lock_fd);
    throw;
  }
  auto& writer = engine.writer_connection();
  // Checked again now that this is the only writer (the file may have changed since the probe).
  if (schema_version(writer) > detail::latest_schema_version())
    fail(Kind::newer_schema, "written by a newer skinspec; left unchanged");
  configure_writer(writer, impl.options);
  detail::migrate(writer, detail::latest_schema_version());
  impl.version = detail::latest_schema_version();
  impl.recovery = detail::recover(writer, impl.options.recovery, {}, impl.now(), impl.options.import_batch);
  engine.start_checkpointer(impl.options.busy_timeout);
  engine.readers().configure(reader_opener(path, SQLITE_OPEN_READONLY, impl.options.busy_timeout),
                             impl.options.max_readers);
}

void open_read_only(Store::Impl& impl, SqliteEngine& engine) {
  struct stat info{};
  if (::stat(impl.path.c_str(), &info) != 0) fail(Kind::not_found, "no database file there");
  if (!S_ISREG(info.st_mode)) fail(Kind::invalid_argument, "not a regular file");
  if (info.st_size == 0) fail(Kind::corrupt, "an empty file, not a skinspec database");
  // Taken before looking for a -wal: a writer that starts in between changes the file after it.
  const auto identity = FileIdentity::of(info);
  const auto access = read_access(impl.path);
  if (access.immutable) engine.freeze(identity);
  try {
    impl.version = probe(access, impl.options);
  } catch (const detail::Failure&) {
    engine.after_read();  // a writer that started meanwhile explains whatever the probe found
    throw;
  }
  engine.after_read();
  if (impl.version == 0) fail(Kind::corrupt, "an empty SQLite database, not a skinspec one");
  detail::refuse_older_schema_for_reading(impl.version);
  engine.readers().configure(reader_opener(access.filename, access.flags, impl.options.busy_timeout),
                             impl.options.max_readers);
}

}  // namespace

std::unique_ptr<Connection> reading_connection(const std::string& path) {
  const auto access = read_access(path);
  return std::make_unique<Connection>(access.filename, access.flags);
}

void open(Store::Impl& impl) {
  auto engine = std::make_unique<SqliteEngine>(impl.path);
  if (impl.options.mode == OpenMode::read_only) {
    open_read_only(impl, *engine);
  } else {
    open_read_write(impl, *engine);
  }
  impl.engine = std::move(engine);
}

void create_at_version(const std::string& path, int version) {
  struct stat info{};
  if (::stat(path.c_str(), &info) == 0) fail(Kind::conflict, "the file exists");
  Connection writer(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  configure_writer(writer, OpenOptions{});
  detail::migrate(writer, version);
}

}  // namespace skinspec::store::sqlite
