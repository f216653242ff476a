#pragma once
// What carries an EventSource to a connection: a thread per stream pulls pieces from the source
// (which may block) and hands them one at a time to the connection's strand, waiting for each
// to be written before pulling the next, so that a slow client holds back its own stream only.

#include <condition_variable>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "skinspec/api/router.hpp"

namespace skinspec::api::detail {

class EventPipe {
 public:
  explicit EventPipe(std::shared_ptr<EventSource> source) : source_(std::move(source)) {}

  EventSource& source() { return *source_; }
  // Waits until the previous piece was written; false when the client is gone.
  bool claim_write();
  // The write of a piece finished (`ok`: it was written).
  void written(bool ok);
  // The client is gone or the server is going away without it: no more writes, the source ends.
  void hang_up();

 private:
  std::shared_ptr<EventSource> source_;
  std::mutex mutex_;
  std::condition_variable done_writing_;
  bool writing_ = false, gone_ = false;
};

// The threads pulling event sources, so that the server can end and join them.
class EventPullers {
 public:
  ~EventPullers() { join_all(); }
  // Runs `pull` on a new thread; joins the threads of streams that have ended.
  void start(const std::shared_ptr<EventPipe>& pipe, std::function<void()> pull);
  // Asks every source to end (the server stops): their streams finish with their last chunk.
  void close_all();
  // Without an event loop left to write: hangs up every stream, then joins the threads.
  void hang_up_and_join();
  void join_all();

 private:
  struct Puller {
    std::shared_ptr<EventPipe> pipe;
    std::shared_ptr<bool> done;  // guarded by mutex_
    std::thread thread;
  };
  std::mutex mutex_;
  std::list<Puller> pullers_;
};

}  // namespace skinspec::api::detail
