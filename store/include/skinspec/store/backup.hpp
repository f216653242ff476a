#pragma once
// Backups of a SQLite store while skinspecd writes it (skinspec backup; docs/store.md,
// "Backups"), and the check of a copy. A PostgreSQL database is backed up with pg_dump.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "skinspec/store/store.hpp"

namespace skinspec::store {

struct BackupReport {
  std::string path;
  int schema_version = 0;
  std::vector<std::pair<std::string, std::int64_t>> rows;  // each table's, by name
  std::int64_t bytes = 0;                                  // of the file
};

// A consistent copy of `from` (a SQLite store, opened to read beside its writer, or alone) at
// `to`, by SQLite's online backup API in one step: every page of one read snapshot, while the
// writer goes on. Written beside `to` under a name of its own, made durable, checked
// (verify_backup) and only then renamed to `to`, so that `to` is a whole backup or absent.
// Refused: a `to` that exists (conflict), a PostgreSQL store (invalid_argument: pg_dump).
Result<BackupReport> backup_database(const Store& from, const std::string& to);

// Checks a copy without changing a byte of it: a skinspec database of a schema version this
// program knows, that passes SQLite's integrity_check; its rows table by table.
Result<BackupReport> verify_backup(const std::string& path);

}  // namespace skinspec::store
