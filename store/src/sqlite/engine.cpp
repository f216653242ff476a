#include "sqlite/engine.hpp"

#include <unistd.h>

#include <algorithm>

namespace skinspec::store::sqlite {

using detail::fail;
using Kind = StoreError::Kind;

// ---- readers ----

detail::ConnectionPool::Opener reader_opener(std::string filename, int flags, std::chrono::milliseconds busy_timeout) {
  return [filename = std::move(filename), flags, busy_timeout]() -> std::unique_ptr<detail::Connection> {
    auto connection = std::make_unique<Connection>(filename, flags);
    sqlite3_busy_timeout(connection->handle(), static_cast<int>(busy_timeout.count()));
    // A reader never writes the database file, not even a checkpoint when it closes.
    sqlite3_db_config(connection->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
    return connection;
  };
}

// ---- FileIdentity ----

FileIdentity FileIdentity::of(const struct stat& info) {
  return {info.st_dev, info.st_ino, info.st_size, info.st_mtim, info.st_ctim};
}

bool FileIdentity::operator==(const FileIdentity& other) const {
  const auto same_time = [](const timespec& a, const timespec& b) {
    return a.tv_sec == b.tv_sec && a.tv_nsec == b.tv_nsec;
  };
  return device == other.device && inode == other.inode && size == other.size && same_time(modified, other.modified) &&
         same_time(changed, other.changed);
}

// ---- SqliteEngine ----

SqliteEngine::~SqliteEngine() {
  readers_.close();
  checkpointer_.reset();
  writer_.reset();  // the last connection out checkpoints the WAL into the database
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void SqliteEngine::set_writer(std::unique_ptr<Connection> writer, int lock_fd) {
  writer_ = std::move(writer);
  lock_fd_ = lock_fd;
}

ConnectionLease SqliteEngine::writer() {
  if (!writer_) fail(Kind::read_only, "the database was opened read-only");
  writer_mutex_.lock();
  return ConnectionLease(*this, *writer_);
}

void SqliteEngine::give_back(detail::Connection&) noexcept { writer_mutex_.unlock(); }

void SqliteEngine::after_read() const {
  if (!frozen_) return;
  struct stat info {};
  if (::stat(path_.c_str(), &info) == 0 && FileIdentity::of(info) == *frozen_) return;
  fail(Kind::busy, "the file changed while it was read (a program started writing it); read it again");
}

}  // namespace skinspec::store::sqlite
