#pragma once
// What a Store holds: its writer connection (behind a mutex), its pool of read connections,
// the lock that makes it the only writer, and the wrappers that turn a body of work into one
// transaction and a Failure into a returned StoreError.

#include <sys/stat.h>

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "skinspec/store/store.hpp"
#include "sqlite.hpp"

namespace skinspec::store {

namespace detail {

// Read connections, opened on demand up to a maximum; a caller beyond it waits.
class ReaderPool {
 public:
  class Lease {
   public:
    Lease(ReaderPool& pool, std::unique_ptr<Connection> connection)
        : pool_(&pool), connection_(std::move(connection)) {}
    ~Lease() { pool_->release(std::move(connection_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Connection& operator*() const { return *connection_; }

   private:
    ReaderPool* pool_;
    std::unique_ptr<Connection> connection_;
  };

  // `filename` and `flags` as for sqlite3_open_v2 (a URI with SQLITE_OPEN_URI).
  void configure(std::string filename, int flags, std::chrono::milliseconds busy_timeout, int max_connections);
  Lease acquire();
  void close();

 private:
  void release(std::unique_ptr<Connection> connection);

  std::string filename_;
  int flags_ = SQLITE_OPEN_READONLY;
  std::chrono::milliseconds busy_timeout_{0};
  int max_ = 1;
  std::mutex mutex_;
  std::condition_variable returned_;
  std::vector<std::unique_ptr<Connection>> idle_;
  int open_ = 0;
};

// What identifies a file's content from outside: a write to it changes at least its times.
struct FileIdentity {
  dev_t device = 0;
  ino_t inode = 0;
  off_t size = 0;
  timespec modified{};
  timespec changed{};

  static FileIdentity of(const struct stat& info);
  bool operator==(const FileIdentity& other) const;
};

// Runs `body`, returning its value, or the StoreError it threw with `what` in front.
template <typename F>
auto guarded(std::string_view what, F&& body) -> Result<std::invoke_result_t<F>> {
  using T = std::invoke_result_t<F>;
  auto with_context = [&](StoreError error) {
    error.message = std::string(what) + ": " + error.message;
    return std::unexpected(std::move(error));
  };
  try {
    if constexpr (std::is_void_v<T>) {
      body();
      return {};
    } else {
      return body();
    }
  } catch (const Failure& failure) {
    return with_context(failure.error);
  } catch (const std::bad_alloc&) {
    return with_context(StoreError{StoreError::Kind::internal, "out of memory", 0});
  }
}

}  // namespace detail

struct Store::Impl {
  std::string path;
  OpenOptions options;
  int version = 0;
  RecoveryReport recovery;
  int lock_fd = -1;  // "<path>-lock", flock()ed while this Store is the writer
  // Read-only without a -wal file, the readers treat the file as immutable (no locks, no -shm):
  // it is what the file was when opened, and a read fails as `busy` once it is not.
  std::optional<detail::FileIdentity> frozen;

  std::mutex writer_mutex;
  std::unique_ptr<detail::Connection> writer;  // null when read-only
  mutable detail::ReaderPool readers;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl();

  Time now() const;
  // Throws `busy` when a frozen file has changed since it was opened.
  void check_still_frozen() const;

  // One write transaction around `body(writer)`, committed when it returns.
  template <typename F>
  auto write(std::string_view what, F&& body) -> Result<std::invoke_result_t<F, detail::Connection&>> {
    if (!writer) {
      return std::unexpected(
          StoreError{StoreError::Kind::read_only, std::string(what) + ": the database was opened read-only", 0});
    }
    std::lock_guard lock(writer_mutex);
    return detail::guarded(what, [&] {
      detail::Transaction transaction(*writer, detail::Transaction::Kind::write);
      auto value = body(*writer);
      transaction.commit();
      return value;
    });
  }

  // One read transaction (a consistent snapshot) on a pooled read connection.
  template <typename F>
  auto read(std::string_view what, F&& body) const -> Result<std::invoke_result_t<F, detail::Connection&>> {
    return detail::guarded(what, [&] {
      auto lease = readers.acquire();
      detail::Transaction transaction(*lease, detail::Transaction::Kind::read);
      auto value = [&] {
        try {
          return body(*lease);
        } catch (const detail::Failure&) {
          check_still_frozen();  // a change under the reader explains whatever it ran into
          throw;
        }
      }();
      transaction.commit();
      check_still_frozen();
      return value;
    });
  }
};

}  // namespace skinspec::store
