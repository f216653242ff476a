#include "sqlite/checkpointer.hpp"

namespace skinspec::store::sqlite {

Checkpointer::Checkpointer(const std::string& path, Connection& writer)
    : connection_(path, SQLITE_OPEN_READWRITE), writer_(writer.handle()) {
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

// Called on the writer's thread after each commit, with the log's length in pages.
int Checkpointer::on_commit(void* self, sqlite3* writer, const char* schema, int pages) {
  if (pages < kPages) return SQLITE_OK;
  auto& checkpointer = *static_cast<Checkpointer*>(self);
  if (pages >= kWriterPages && pages - checkpointer.copied_.load() < kPages) {
    // The thread is not woken, so at most one commit finds it still copying (busy).
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
    int copied = 0;
    if (sqlite3_wal_checkpoint_v2(connection_.handle(), nullptr, SQLITE_CHECKPOINT_PASSIVE, nullptr, &copied) ==
        SQLITE_OK)
      copied_ = copied;
  }
}

}  // namespace skinspec::store::sqlite
