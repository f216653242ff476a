#pragma once
// Opening a SQLite file as a Store (docs/store.md, "Opening").

#include <string>

#include <memory>

#include "sqlite/connection.hpp"
#include "store_impl.hpp"

namespace skinspec::store::sqlite {

// Opens the file at impl.path as impl.options say; sets impl.engine, version and recovery.
void open(Store::Impl& impl);

// A connection that only reads the file at `path` and creates nothing beside it, as a read-only
// Store reads it (through its writer's log when one is live, else as immutable).
std::unique_ptr<Connection> reading_connection(const std::string& path);

// A new file at `path` holding the schema of `version` and nothing else.
void create_at_version(const std::string& path, int version);

}  // namespace skinspec::store::sqlite
