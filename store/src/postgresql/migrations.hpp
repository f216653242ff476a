#pragma once
// The PostgreSQL schema: a baseline step that makes the whole schema of kPostgresqlBaseline,
// then a step per later version. A skinspec database is known by its table skinspec_schema,
// whose one row holds the version.

#include "schema.hpp"

namespace skinspec::store::postgresql {

extern const detail::MigrationStep kBaseline;
extern const detail::MigrationStep kVersion6;
extern const detail::MigrationStep kVersion7;
extern const detail::MigrationStep kVersion8;
extern const detail::MigrationStep kVersion9;
extern const detail::MigrationStep kVersion10;
extern const detail::MigrationStep kVersion11;

// The version of the database `writer` is connected to; 0 for an empty one. Throws corrupt for
// a database whose schema holds another application's tables.
int schema_version(detail::Connection& writer);
void set_schema_version(detail::Connection& writer, int version);

// Waits for the lock that lets one program at a time migrate the database; the transaction
// holds it until it ends. So two daemons starting at once migrate once: the second finds the
// version the first left.
void lock_schema(detail::Connection& writer);

}  // namespace skinspec::store::postgresql
