// Opening a PostgreSQL database: the checks made before anything is written (another
// application's database, a newer schema, a role that may not write), the writer lock,
// migrations under the schema lock, recovery; the read pool.

#include "postgresql/open.hpp"

#include <fmt/format.h>

#include "postgresql/engine.hpp"
#include "postgresql/migrations.hpp"
#include "recovery.hpp"

namespace skinspec::store::postgresql {

using detail::fail;
using Kind = StoreError::Kind;

namespace {

// Text outside the database's encoding could not be stored: a skinspec database is UTF-8, as
// every text of the store is.
void require_utf8(detail::Connection& connection) {
  const auto encoding = connection.query_text("SELECT current_setting('server_encoding')");
  if (encoding != "UTF8")
    fail(Kind::invalid_argument,
         fmt::format("the database's encoding is {}; skinspec needs UTF8 (createdb --encoding UTF8)", encoding));
}

int version_of(detail::Connection& connection, TransactionKind kind) {
  detail::Transaction transaction(connection, kind);
  if (kind == TransactionKind::write) lock_schema(connection);  // not half way through another's migration
  const int version = schema_version(connection);
  transaction.commit();
  return version;
}

// A role that may read but not write is refused at once, not at its first measurement.
void require_writable(detail::Connection& writer, const Target& target, int version) {
  if (writer.query_text("SELECT current_setting('default_transaction_read_only')") == "on")
    fail(Kind::read_only, fmt::format("role {} only reads (default_transaction_read_only is on)", target.user));
  if (version == 0) return;  // nothing yet: creating the schema checks the role may
  const auto refused = writer.query_integer(
      "SELECT count(*) FROM pg_catalog.pg_class c JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace "
      "WHERE n.nspname = current_schema() AND c.relkind = 'r' AND c.relname <> 'skinspec_schema' "
      "AND NOT (has_table_privilege(c.oid, 'INSERT') AND has_table_privilege(c.oid, 'UPDATE'))");
  if (refused > 0)
    fail(Kind::read_only, fmt::format("role {} may not write {} of the database's tables", target.user, refused));
}

void open_read_write(Store::Impl& impl, const Target& target, PgEngine& engine) {
  auto& writer = engine.connect_writer();
  require_utf8(writer);
  const int version = version_of(writer, TransactionKind::write);
  detail::refuse_newer_schema(version);
  require_writable(writer, target, version);
  detail::migrate(writer, detail::latest_schema_version());
  impl.version = detail::latest_schema_version();
  impl.recovery =
      detail::recover(writer, impl.options.recovery, {impl.options.bench}, impl.now(), impl.options.import_batch);
}

void open_read_only(Store::Impl& impl, PgEngine& engine) {
  auto reader = engine.reader();
  require_utf8(*reader);
  impl.version = version_of(*reader, TransactionKind::read);
  detail::refuse_newer_schema(impl.version);
  if (impl.version == 0) fail(Kind::corrupt, "an empty database, not a skinspec one");
  detail::refuse_older_schema_for_reading(impl.version);
}

}  // namespace

void open(Store::Impl& impl) {
  const auto target = parse_target(impl.path);
  const bool writes = impl.options.mode == OpenMode::read_write;
  auto engine = std::make_unique<PgEngine>(target, writes, impl.options.max_readers, impl.options.bench);
  if (writes) {
    open_read_write(impl, target, *engine);
  } else {
    open_read_only(impl, *engine);
  }
  impl.engine = std::move(engine);
}

}  // namespace skinspec::store::postgresql
