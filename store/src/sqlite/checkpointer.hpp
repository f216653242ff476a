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
// past kWriterPages and the thread has copied most of it, the writer copies the rest itself,
// as SQLite would have copied all of it; and past kMostPages it copies whatever is left, as
// soon as the thread is not copying, should the thread fall behind for good.

#include <sqlite3.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
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
  static constexpr int kMostPages = 64 * kPages;

  // Opens its connection to `path` (durable and patient as the writer is) and takes over
  // `writer`'s checkpoints (its commit hook).
  Checkpointer(const std::string& path, Connection& writer, std::chrono::milliseconds busy_timeout);
  // Stops once the checkpoint under way, if any, is done, and gives the writer its own hook back.
  ~Checkpointer();
  Checkpointer(const Checkpointer&) = delete;
  Checkpointer& operator=(const Checkpointer&) = delete;

 private:
  static int on_commit(void* self, sqlite3* writer, const char* schema, int pages);
  // On the writer's thread: the pages of a log of `pages` the thread has not copied, as far as
  // it is known (all of them when not).
  int left_to_copy(int pages);
  void run(const std::stop_token& stop);

  Connection connection_;
  sqlite3* writer_;
  std::mutex mutex_;
  std::condition_variable_any due_changed_;
  bool due_ = false;
  // The writer's: the log's length at the last commit, and how often it was written from its
  // start again (a shorter log than before).
  int last_pages_ = 0;
  std::atomic<std::uint32_t> restarts_{0};
  // The thread's last checkpoint: the restarts it began after (high half) and the pages it had
  // copied (low half), in one word so that the writer never reads one without the other.
  std::atomic<std::uint64_t> copied_{0};
  std::jthread thread_;  // last: started once everything it uses exists, stopped first
};

}  // namespace skinspec::store::sqlite
