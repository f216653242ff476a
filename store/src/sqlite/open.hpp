#pragma once
// Opening a SQLite file as a Store (docs/store.md, "Opening").

#include <string>

#include "store_impl.hpp"

namespace skinspec::store::sqlite {

// Opens the file at impl.path as impl.options say; sets impl.engine, version and recovery.
void open(Store::Impl& impl);

// A new file at `path` holding the schema of `version` and nothing else.
void create_at_version(const std::string& path, int version);

}  // namespace skinspec::store::sqlite
