// Backups of a live SQLite store through SQLite's online backup API (sqlite3_backup_*).

#include "skinspec/store/backup.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>

#include "sqlite/connection.hpp"
#include "sqlite/open.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

namespace {

namespace fs = std::filesystem;
using Kind = StoreError::Kind;

// Makes a file's (or a directory's) contents durable.
void sync_path(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  if (fd >= 0) ::close(fd);
  if (!synced) detail::fail(Kind::io, fmt::format("{} cannot be made durable", path.string()));
}

// Copies every page of `source` into `destination` in one step: one read snapshot of the source,
// which a writer in WAL mode never waits for.
void copy_pages(sqlite::Connection& source, sqlite::Connection& destination) {
  sqlite3_backup* backup = sqlite3_backup_init(destination.handle(), "main", source.handle(), "main");
  if (backup == nullptr) destination.fail(sqlite3_errcode(destination.handle()));
  int rc = SQLITE_OK;
  for (int tries = 0; tries < 50; ++tries) {
    rc = sqlite3_backup_step(backup, -1);
    if (rc != SQLITE_BUSY && rc != SQLITE_LOCKED) break;
    sqlite3_sleep(100);  // the source's writer is checkpointing: its lock is brief
  }
  const int finished = sqlite3_backup_finish(backup);
  if (rc != SQLITE_DONE) sqlite::fail(rc, fmt::format("the backup stopped: {}", sqlite3_errstr(rc)));
  if (finished != SQLITE_OK) destination.fail(finished);
}

std::vector<std::pair<std::string, std::int64_t>> rows_by_table(sqlite::Connection& c) {
  std::vector<std::string> tables;
  {
    auto names =
        c.prepare("SELECT name FROM sqlite_schema WHERE type = 'table' AND name NOT LIKE 'sqlite_%' ORDER BY name");
    while (names.step()) tables.push_back(names.text(0));
  }
  std::vector<std::pair<std::string, std::int64_t>> rows;
  // The names are the schema's own, read just now: quoted, never a caller's text.
  for (const auto& table : tables)
    rows.emplace_back(table, c.query_integer(fmt::format("SELECT count(*) FROM \"{}\"", table)));
  return rows;
}

BackupReport verify(const std::string& path) {
  if (!fs::is_regular_file(path)) detail::fail(Kind::not_found, fmt::format("{}: no such file", path));
  // Opening checks what it is (a skinspec database, not newer than this program) and reads it
  // as immutable when nothing writes it: no byte of it changes, nothing is made beside it.
  OpenOptions options;
  options.mode = OpenMode::read_only;
  options.check_integrity = false;  // the whole integrity_check follows
  auto opened = Store::open(path, options);
  if (!opened && opened.error().kind != Kind::older_schema) throw detail::Failure{opened.error()};
  const auto reading = sqlite::reading_connection(path);
  sqlite::Connection& c = *reading;
  const auto verdict = c.query_text("PRAGMA integrity_check(1)");
  if (verdict != "ok") detail::fail(Kind::corrupt, fmt::format("{}: damaged: {}", path, verdict));
  BackupReport report;
  report.path = path;
  report.schema_version = static_cast<int>(c.query_integer("PRAGMA user_version"));
  report.rows = rows_by_table(c);
  report.bytes = static_cast<std::int64_t>(fs::file_size(path));
  return report;
}

}  // namespace

Result<BackupReport> verify_backup(const std::string& path) {
  return detail::guarded(fmt::format("checking {}", path), [&] { return verify(path); });
}

Result<BackupReport> backup_database(const Store& from, const std::string& to) {
  return detail::guarded(fmt::format("backing up {} to {}", from.path(), to), [&] {
    if (from.backend() != Backend::sqlite)
      detail::fail(Kind::invalid_argument,
                   "a PostgreSQL database is backed up with pg_dump (docs/store.md, \"Backups\")");
    std::error_code error;
    if (fs::exists(to, error))
      detail::fail(Kind::conflict, fmt::format("{} exists: a backup never replaces a file", to));
    const fs::path target = fs::absolute(to);
    const fs::path partial =
        target.parent_path() / fmt::format(".{}.partial-{}", target.filename().string(), ::getpid());
    fs::remove(partial, error);
    try {
      {
        auto source = from.impl_->engine->reader();
        sqlite::Connection destination(partial.string(), SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
        copy_pages(dynamic_cast<sqlite::Connection&>(*source), destination);
        // A copy of its own: no -wal beside it, so that it is read as it is.
        destination.execute("PRAGMA journal_mode = DELETE");
        from.impl_->engine->after_read();
      }
      sync_path(partial);
      (void)verify(partial.string());
      fs::rename(partial, target);
      sync_path(target.parent_path());
    } catch (...) {
      fs::remove(partial, error);
      throw;
    }
    auto report = verify(target.string());
    return report;
  });
}

}  // namespace skinspec::store
