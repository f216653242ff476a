#pragma once
// The SQLite schema, version by version; the version is PRAGMA user_version and a skinspec
// file is known by its PRAGMA application_id.

#include <cstdint>

#include "schema.hpp"

namespace skinspec::store::sqlite {

// PRAGMA application_id of a skinspec database: "SKSP".
inline constexpr std::int64_t kApplicationId = 0x534B5350;

extern const detail::MigrationStep kVersion1;
extern const detail::MigrationStep kVersion2;
extern const detail::MigrationStep kVersion3;
extern const detail::MigrationStep kVersion4;
extern const detail::MigrationStep kVersion5;
extern const detail::MigrationStep kVersion6;
extern const detail::MigrationStep kVersion8;
extern const detail::MigrationStep kVersion9;
extern const detail::MigrationStep kVersion10;
extern const detail::MigrationStep kVersion11;

int schema_version(detail::Connection& writer);
void set_schema_version(detail::Connection& writer, int version);

}  // namespace skinspec::store::sqlite
