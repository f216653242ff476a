#pragma once
// The schema as a list of forward-only migrations; migration N takes a database from
// user_version N-1 to N. Applied migrations are never edited: a change is a new migration.

#include <cstdint>
#include <string_view>

#include "sqlite.hpp"

namespace skinspec::store::detail {

// PRAGMA application_id of a skinspec database: "SKSP".
inline constexpr std::int64_t kApplicationId = 0x534B5350;

int latest_schema_version();

// Applies the migrations after the database's user_version up to `target`, each in its own
// write transaction (so a crash leaves it at a whole version).
void migrate(Connection& writer, int target);

}  // namespace skinspec::store::detail
