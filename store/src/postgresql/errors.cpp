#include "postgresql/errors.hpp"

#include <array>
#include <utility>

namespace skinspec::store::postgresql {

namespace {

using Kind = StoreError::Kind;

// Whole codes first, then classes (the first two characters), as PostgreSQL's appendix A
// groups them.
constexpr std::array<std::pair<std::string_view, Kind>, 19> kCodes = {{
    {"53100", Kind::full},           // disk_full
    {"53300", Kind::busy},           // too_many_connections
    {"25006", Kind::read_only},      // read_only_sql_transaction
    {"42501", Kind::read_only},      // insufficient_privilege
    {"40001", Kind::busy},           // serialization_failure
    {"40P01", Kind::busy},           // deadlock_detected
    {"55P03", Kind::busy},           // lock_not_available
    {"57P01", Kind::unreachable},    // admin_shutdown
    {"57P02", Kind::unreachable},    // crash_shutdown
    {"57P03", Kind::unreachable},    // cannot_connect_now
    {"28000", Kind::access_denied},  // invalid_authorization_specification
    {"28P01", Kind::access_denied},  // invalid_password
    {"3D000", Kind::not_found},      // invalid_catalog_name (no such database)
    {"42P01", Kind::corrupt},        // undefined_table: not the schema this program expects
    {"42703", Kind::corrupt},        // undefined_column: likewise
    {"XX001", Kind::corrupt},        // data_corrupted
    {"XX002", Kind::corrupt},        // index_corrupted
    {"58030", Kind::io},             // io_error
    {"58P01", Kind::io},             // undefined_file
}};

constexpr std::array<std::pair<std::string_view, Kind>, 5> kClasses = {{
    {"23", Kind::conflict},          // integrity constraint violation
    {"22", Kind::invalid_argument},  // data exception
    {"54", Kind::invalid_argument},  // program limit exceeded (a value too large)
    {"08", Kind::unreachable},       // connection exception
    {"53", Kind::busy},              // insufficient resources (out of memory, ...)
}};

}  // namespace

StoreError::Kind kind_of_sql_state(std::string_view sql_state) {
  for (const auto& [code, kind] : kCodes)
    if (sql_state == code) return kind;
  for (const auto& [prefix, kind] : kClasses)
    if (sql_state.starts_with(prefix)) return kind;
  return Kind::internal;
}

bool retryable_sql_state(std::string_view sql_state) {
  return sql_state == "40001" || sql_state == "40P01" || sql_state == "55P03";
}

bool connection_lost_sql_state(std::string_view sql_state) {
  return sql_state.starts_with("08") || sql_state == "57P01" || sql_state == "57P02" || sql_state == "57P03";
}

}  // namespace skinspec::store::postgresql
