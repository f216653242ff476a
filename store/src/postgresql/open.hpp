#pragma once
// Opening a PostgreSQL database as a Store (docs/store.md, "PostgreSQL").

#include "store_impl.hpp"

namespace skinspec::store::postgresql {

// Opens the database impl.path (a libpq URI) names as impl.options say; sets impl.engine,
// version and recovery.
void open(Store::Impl& impl);

}  // namespace skinspec::store::postgresql
