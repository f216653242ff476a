#include "sqlite/checkpointer.hpp"

#include <algorithm>

namespace skinspec::store::sqlite {

Checkpointer::Checkpointer(const std::string& path, Connection& writer, std::chrono::milliseconds busy_timeout)
    : connection_(path, SQLITE_OPEN_READWRITE), writer_(writer.handle()) {
  sqlite3_busy_timeout(connection_.handle(), static_cast<int>(busy_timeout.count()));
  // The file synced before the writer may write the log from its start again.
  connection_.execute("PRAGMA synchronous = FULL");
  // Closing this connection must not checkpoint: the writer's, closed last, does.
  sqlite3_db_config(connection_.handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
  // A connection learns that the file is in WAL mode when it first reads it; until then a
  // checkpoint on it does nothing.
  (void)connection_.query_integer("PRAGMA schema_version");
  thread_ = std::jthread([this](const std::stop_token& stop) { run(stop); });
  sqlite3_wal_hook(writer_, &Checkpointer::on_commit, this);
}

Checkpointer::~Checkpointer() {
  sqlite3_wal_autocheckpoint(writer_, kPages);  // the writer's hook back before this goes
  thread_.request_stop();
  thread_.join();
}

int Checkpointer::left_to_copy(int pages) {
  if (pages < last_pages_) ++restarts_;
  last_pages_ = pages;
  const std::uint64_t copied = copied_.load();
  if (copied >> 32 != restarts_.load()) return pages;  // copied from an earlier log, or never
  return std::max(pages - static_cast<int>(copied & 0xffffffffu), 0);
}

// Called on the writer's thread after each commit, with the log's length in pages.
int Checkpointer::on_commit(void* self, sqlite3* writer, const char* schema, int pages) {
  auto& checkpointer = *static_cast<Checkpointer*>(self);
  const int previous = checkpointer.last_pages_;
  const int left = checkpointer.left_to_copy(pages);
  if (pages < kPages) return SQLITE_OK;
  const bool little_left = pages >= kWriterPages && left < std::max(kPages, pages / 4);
  const bool too_long = previous >= kMostPages && pages >= previous;  // so over more than one commit
  if (little_left || too_long) {
    // Busy while the thread copies: the next commit tries again, without waking it.
    (void)sqlite3_wal_checkpoint_v2(writer, schema, SQLITE_CHECKPOINT_PASSIVE, nullptr, nullptr);
    return SQLITE_OK;
  }
  {
    std::lock_guard lock(checkpointer.mutex_);
    checkpointer.due_ = true;
  }
  checkpointer.due_changed_.notify_one();
  return SQLITE_OK;
}

void Checkpointer::run(const std::stop_token& stop) {
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      if (!due_changed_.wait(lock, stop, [this] { return due_; })) return;
      due_ = false;
    }
    // PASSIVE: copies what no reader still needs, and never waits for the writer nor the
    // readers. A log not copied whole is copied on the next call.
    const std::uint64_t restarts = restarts_.load();
    int copied = 0;
    if (sqlite3_wal_checkpoint_v2(connection_.handle(), nullptr, SQLITE_CHECKPOINT_PASSIVE, nullptr, &copied) ==
            SQLITE_OK &&
        copied >= 0)
      copied_ = restarts << 32 | static_cast<std::uint32_t>(copied);
  }
}

}  // namespace skinspec::store::sqlite
