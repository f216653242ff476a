// Opening a store on the engine its target names; the accessors.

#include <fmt/format.h>

#include "postgresql/open.hpp"
#include "postgresql/target.hpp"
#include "schema.hpp"
#include "sqlite/open.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

using detail::fail;
using Kind = StoreError::Kind;

Time Store::Impl::now() const {
  if (options.clock) return options.clock();
  return std::chrono::floor<std::chrono::microseconds>(std::chrono::system_clock::now());
}

Time Store::Impl::database_now(detail::Connection& c) const {
  if (options.clock || backend == Backend::sqlite) return now();
  auto row = c.prepare("SELECT clock_timestamp()");
  if (!row.step()) fail(Kind::internal, "the database server gave no time");
  const Time server = row.time(0);
  row.run();
  return server;
}

namespace {

// A SQLite target's file: the path, without "sqlite:" when it was given so.
std::string sqlite_path(const std::string& target) { return target.starts_with("sqlite:") ? target.substr(7) : target; }

}  // namespace

Result<Store> Store::open(const std::string& target, const OpenOptions& options) {
  const auto backend = backend_of(target);
  const auto path = backend == Backend::sqlite ? sqlite_path(target) : target;
  const auto shown = backend == Backend::postgresql ? "the database" : "the database file";
  return detail::guarded(fmt::format("opening {} {}", shown, display_target(target)), [&] {
    auto impl = std::make_unique<Impl>();
    impl->path = path;
    impl->backend = backend;
    impl->options = options;
    if (options.import_batch < 1)
      fail(Kind::invalid_argument, fmt::format("an import batch of {} measurements", options.import_batch));
    if (backend == Backend::postgresql) {
      postgresql::open(*impl);
    } else {
      if (path.empty() || path == ":memory:" || path.starts_with("file:"))
        fail(Kind::invalid_argument, "the database must be a file path");
      sqlite::open(*impl);
    }
    return Store(std::move(impl));
  });
}

Backend backend_of(const std::string& target) {
  return postgresql::is_postgresql_uri(target) ? Backend::postgresql : Backend::sqlite;
}

std::string display_target(const std::string& target) {
  if (backend_of(target) == Backend::postgresql) return postgresql::display_form(target);
  return sqlite_path(target);
}

Store::Store(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

const std::string& Store::path() const { return impl_->path; }
Backend Store::backend() const { return impl_->backend; }
int Store::schema_version() const { return impl_->version; }
const RecoveryReport& Store::recovery() const { return impl_->recovery; }

int current_schema_version() { return detail::latest_schema_version(); }

Result<void> create_database_at_version(const std::string& path, int version) {
  return detail::guarded(fmt::format("creating a version-{} database at {}", version, path), [&] {
    if (version < 1 || version > detail::latest_schema_version())
      fail(Kind::invalid_argument, fmt::format("versions are 1 to {}", detail::latest_schema_version()));
    sqlite::create_at_version(path, version);
  });
}

}  // namespace skinspec::store
