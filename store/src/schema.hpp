#pragma once
// The schema as one list of forward-only migrations; entry N takes a database to version N,
// with a step written in each engine's dialect. Applied migrations are never edited: a change
// is a new entry, written for every engine.

#include <span>
#include <string_view>

#include "db.hpp"

namespace skinspec::store::detail {

// One step in one dialect: `sql`, then the rows converted where SQL alone would not say it
// plainly, then `after_sql`.
struct MigrationStep {
  std::string_view sql;
  void (*convert_rows)(Connection&) = nullptr;
  std::string_view after_sql = {};
};

// The step of a version that changes nothing on one engine (a setting only the other has).
inline constexpr MigrationStep kUnchanged{""};

struct Migration {
  int version;                      // the version this entry makes
  const MigrationStep* sqlite;      // from the version before
  const MigrationStep* postgresql;  // from the version before; none before kPostgresqlBaseline
};

// PostgreSQL databases start at this version: its first step makes the whole schema of it.
inline constexpr int kPostgresqlBaseline = 5;

std::span<const Migration> migrations();
int latest_schema_version();

// Throws newer_schema for a database written by a newer skinspec, left as it is.
void refuse_newer_schema(int version);
// Throws older_schema for a database opened to read that needs migrating first.
void refuse_older_schema_for_reading(int version);

// Applies the steps of the writer's dialect after the database's version up to `target`, each
// in its own write transaction (so a crash leaves it at a whole version).
void migrate(Connection& writer, int target);

}  // namespace skinspec::store::detail
