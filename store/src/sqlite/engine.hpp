#pragma once
// The SQLite engine: one file, one writer connection behind a mutex (the advisory lock on
// "PATH-lock" makes this Store the only writer), a pool of read connections, and what opening
// a file involves (sqlite/open.cpp).

#include <sys/stat.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "../connection_pool.hpp"
#include "../engine.hpp"
#include "skinspec/store/store.hpp"
#include "sqlite/checkpointer.hpp"
#include "sqlite/connection.hpp"

namespace skinspec::store::sqlite {

using detail::ConnectionLease;

// How the pool opens a read connection to `filename` (a URI with SQLITE_OPEN_URI in `flags`).
detail::ConnectionPool::Opener reader_opener(std::string filename, int flags, std::chrono::milliseconds busy_timeout);

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

class SqliteEngine final : public detail::Engine, private ConnectionLease::Owner {
 public:
  explicit SqliteEngine(std::string path) : path_(std::move(path)) {}
  ~SqliteEngine() override;
  SqliteEngine(const SqliteEngine&) = delete;
  SqliteEngine& operator=(const SqliteEngine&) = delete;

  Dialect dialect() const override { return Dialect::sqlite; }
  ConnectionLease writer() override;
  ConnectionLease reader() override { return readers_.acquire(); }
  // Throws `busy` when a file read as immutable has changed since it was opened.
  void after_read() const override;

  // Set while opening (sqlite/open.cpp).
  const std::string& path() const { return path_; }
  void set_writer(std::unique_ptr<Connection> writer, int lock_fd);
  Connection& writer_connection() { return *writer_; }
  // From here on the writer's checkpoints run beside it (once the file is migrated).
  void start_checkpointer(std::chrono::milliseconds busy_timeout) {
    checkpointer_ = std::make_unique<Checkpointer>(path_, *writer_, busy_timeout);
  }
  void freeze(const FileIdentity& identity) { frozen_ = identity; }
  detail::ConnectionPool& readers() { return readers_; }

 private:
  void give_back(detail::Connection& connection) noexcept override;

  std::string path_;
  int lock_fd_ = -1;  // "<path>-lock", flock()ed while this Store is the writer
  // Read-only without a -wal file, the readers treat the file as immutable (no locks, no -shm):
  // it is what the file was when opened, and a read fails as `busy` once it is not.
  std::optional<FileIdentity> frozen_;
  std::mutex writer_mutex_;
  std::unique_ptr<Connection> writer_;          // null when read-only
  std::unique_ptr<Checkpointer> checkpointer_;  // null when read-only or still opening
  detail::ConnectionPool readers_;
};

}  // namespace skinspec::store::sqlite
