#include "schema.hpp"

#include <fmt/format.h>

#include <array>

#include "postgresql/migrations.hpp"
#include "sqlite/migrations.hpp"

namespace skinspec::store::detail {

namespace {

constexpr std::array<Migration, 11> kMigrations = {{
    {1, &sqlite::kVersion1, nullptr},
    {2, &sqlite::kVersion2, nullptr},
    {3, &sqlite::kVersion3, nullptr},
    {4, &sqlite::kVersion4, nullptr},
    {5, &sqlite::kVersion5, &postgresql::kBaseline},
    {6, &sqlite::kVersion6, &postgresql::kVersion6},
    {7, &kUnchanged, &postgresql::kVersion7},
    {8, &sqlite::kVersion8, &postgresql::kVersion8},
    {9, &sqlite::kVersion9, &postgresql::kVersion9},
    {10, &sqlite::kVersion10, &postgresql::kVersion10},
    {11, &sqlite::kVersion11, &postgresql::kVersion11},
}};

constexpr bool numbered_in_order() {
  for (std::size_t i = 0; i < kMigrations.size(); ++i)
    if (kMigrations[i].version != static_cast<int>(i) + 1) return false;
  return true;
}
static_assert(numbered_in_order(), "one entry per version, from 1");

const MigrationStep* step_of(const Migration& migration, Dialect dialect) {
  return dialect == Dialect::sqlite ? migration.sqlite : migration.postgresql;
}

int schema_version(Connection& writer) {
  if (writer.dialect() == Dialect::sqlite) return sqlite::schema_version(writer);
  return postgresql::schema_version(writer);
}

void set_schema_version(Connection& writer, int version) {
  if (writer.dialect() == Dialect::sqlite) return sqlite::set_schema_version(writer, version);
  postgresql::set_schema_version(writer, version);
}

// The first entry after `version` written for `dialect`.
const Migration* next_after(int version, Dialect dialect) {
  for (const auto& migration : kMigrations)
    if (migration.version > version && step_of(migration, dialect) != nullptr) return &migration;
  return nullptr;
}

}  // namespace

std::span<const Migration> migrations() { return kMigrations; }

int latest_schema_version() { return kMigrations.back().version; }

void refuse_newer_schema(int version) {
  if (version <= latest_schema_version()) return;
  fail(StoreError::Kind::newer_schema,
       fmt::format("written by a newer skinspec (schema version {}; this program knows versions up to {}); left "
                   "unchanged",
                   version, latest_schema_version()));
}

void refuse_older_schema_for_reading(int version) {
  if (version >= latest_schema_version()) return;
  fail(StoreError::Kind::older_schema,
       fmt::format("schema version {} is older than this program's {}; it is migrated when skinspecd next opens "
                   "it, and left unchanged here",
                   version, latest_schema_version()));
}

void migrate(Connection& writer, int target) {
  for (;;) {
    Transaction transaction(writer, TransactionKind::write);
    if (writer.dialect() == Dialect::postgresql) postgresql::lock_schema(writer);
    // Read inside the transaction: the version cannot change under us once we hold it.
    const auto version = schema_version(writer);
    if (version >= target) return;
    if (version < 0)
      fail(StoreError::Kind::corrupt, fmt::format("schema version {} is not one skinspec writes", version));
    const auto* next = next_after(version, writer.dialect());
    if (next == nullptr || next->version > target)
      fail(StoreError::Kind::internal, fmt::format("no migration leads from version {} to {}", version, target));
    const auto& step = *step_of(*next, writer.dialect());
    writer.execute(step.sql);
    if (step.convert_rows) step.convert_rows(writer);
    if (!step.after_sql.empty()) writer.execute(step.after_sql);
    set_schema_version(writer, next->version);
    transaction.commit();
  }
}

}  // namespace skinspec::store::detail
