#include "sqlite/engine.hpp"

#include <unistd.h>

#include <algorithm>

#include "codec.hpp"

namespace skinspec::store::sqlite {

using detail::fail;
using detail::Transaction;
using Kind = StoreError::Kind;

// ---- ReaderPool ----

void ReaderPool::configure(std::string filename, int flags, std::chrono::milliseconds busy_timeout,
                           int max_connections) {
  filename_ = std::move(filename);
  flags_ = flags;
  busy_timeout_ = busy_timeout;
  max_ = static_cast<std::size_t>(std::max(1, max_connections));
}

ConnectionLease ReaderPool::acquire() {
  std::unique_lock lock(mutex_);
  returned_.wait(lock, [&] { return !idle_.empty() || open_.size() + opening_ < max_; });
  if (!idle_.empty()) {
    auto* connection = idle_.back();
    idle_.pop_back();
    return ConnectionLease(*this, *connection);
  }
  ++opening_;
  lock.unlock();
  std::unique_ptr<Connection> connection;
  try {
    connection = std::make_unique<Connection>(filename_, flags_);
    sqlite3_busy_timeout(connection->handle(), static_cast<int>(busy_timeout_.count()));
    // A reader never writes the database file, not even a checkpoint when it closes.
    sqlite3_db_config(connection->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
  } catch (...) {
    lock.lock();
    --opening_;
    returned_.notify_one();
    throw;
  }
  lock.lock();
  --opening_;
  auto& opened = *open_.emplace_back(std::move(connection));
  return ConnectionLease(*this, opened);
}

void ReaderPool::give_back(detail::Connection& connection) noexcept {
  {
    std::lock_guard lock(mutex_);
    idle_.push_back(&connection);
  }
  returned_.notify_one();
}

void ReaderPool::close() {
  std::lock_guard lock(mutex_);
  idle_.clear();
  open_.clear();
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

// ---- recovery ----

// Such a job has stored nothing: a job's measurement is stored in the transaction that ends it
// (complete_measurement_job).
RecoveryReport recover(detail::Connection& writer, RecoveryPolicy policy, Time now) {
  RecoveryReport report;
  Transaction transaction(writer, detail::TransactionKind::write);
  {
    auto running = writer.prepare(policy == RecoveryPolicy::all_open_sessions
                                      ? "SELECT id FROM sessions WHERE state = 'open' ORDER BY id"
                                      : "SELECT DISTINCT s.id FROM sessions s JOIN jobs j ON j.session_id = s.id "
                                        "WHERE s.state = 'open' AND j.state IN ('queued', 'running') ORDER BY s.id");
    while (running.step()) report.interrupted_sessions.push_back(running.integer(0));
  }
  {
    auto active = writer.prepare("SELECT id FROM jobs WHERE state IN ('queued', 'running') ORDER BY id");
    while (active.step()) report.failed_jobs.push_back(active.integer(0));
  }
  const auto interrupted =
      detail::encode_job_error({JobErrorCode::interrupted, "the program running it stopped before it finished"});
  for (const Id id : report.interrupted_sessions) {
    writer.prepare("UPDATE sessions SET state = 'interrupted', updated_at = ?2, ended_at = ?2 WHERE id = ?1")
        .bind(id, now)
        .run();
  }
  for (const Id id : report.failed_jobs) {
    writer.prepare("UPDATE jobs SET state = 'failed', error = ?2, finished_at = ?3 WHERE id = ?1")
        .bind(id, interrupted, now)
        .run();
  }
  transaction.commit();
  return report;
}

}  // namespace skinspec::store::sqlite
