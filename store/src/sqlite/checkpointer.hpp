#pragma once
// Copies the write-ahead log back into the database file on a thread and connection of its own.
// SQLite's automatic checkpoint runs inside the commit that crosses its threshold, so a writer
// committing batch after batch would wait for the copy (reading the log, writing the file,
// syncing it) every few commits; here the writer only says the log is long enough, and goes on.
// A checkpoint that fails (a full disk) loses nothing: the log keeps the pages, and the next
// one tries again.
//
// The log is written from its start again only when a checkpoint has copied all of it before
// the writer's next transaction begins; behind a writer that never pauses, the thread's copy
// always ends a commit or two short, and the log would grow without end. So once the log is
// past kWriterPages and the thread has left less than kPages of it, the writer copies that
// rest itself, as SQLite would have copied all of it.

#include <sqlite3.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include "sqlite/connection.hpp"

namespace skinspec::store::sqlite {

class Checkpointer {
 public:
  // SQLite's own threshold: a log of this many pages is copied into the file.
  static constexpr int kPages = 1000;
  static constexpr int kWriterPages = 4 * kPages;

  // Opens its connection to `path` and takes over `writer`'s checkpoints (its commit hook).
  Checkpointer(const std::string& path, Connection& writer);
  // Stops after the checkpoint under way, if any, and gives the writer its own hook back.
  ~Checkpointer();
  Checkpointer(const Checkpointer&) = delete;
  Checkpointer& operator=(const Checkpointer&) = delete;

 private:
  static int on_commit(void* self, sqlite3* db, const char* schema, int pages);
  void run(const std::stop_token& stop);

  Connection connection_;
  sqlite3* writer_;
  std::mutex mutex_;
  std::condition_variable_any due_changed_;
  bool due_ = false;
  std::atomic<int> copied_{0};  // the log's pages in the file after the thread's last checkpoint
  std::jthread thread_;         // last: started once everything it uses exists, stopped first
};

}  // namespace skinspec::store::sqlite
