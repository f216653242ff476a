// Opening a store on the engine its target names; the accessors.

#include <fmt/format.h>

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

Result<Store> Store::open(const std::string& path, const OpenOptions& options) {
  return detail::guarded(fmt::format("opening the database {}", path), [&] {
    if (path.empty() || path == ":memory:" || path.starts_with("file:"))
      fail(Kind::invalid_argument, "the database must be a file path");
    auto impl = std::make_unique<Impl>();
    impl->path = path;
    impl->options = options;
    sqlite::open(*impl);
    return Store(std::move(impl));
  });
}

Store::Store(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

const std::string& Store::path() const { return impl_->path; }
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
