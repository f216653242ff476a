#include "event_pipe.hpp"

namespace skinspec::api::detail {

bool EventPipe::claim_write() {
  std::unique_lock lock(mutex_);
  done_writing_.wait(lock, [this] { return !writing_ || gone_; });
  if (gone_) return false;
  writing_ = true;
  return true;
}

void EventPipe::written(bool ok) {
  {
    std::lock_guard lock(mutex_);
    writing_ = false;
    gone_ = gone_ || !ok;
  }
  done_writing_.notify_all();
  if (!ok) source_->close();
}

void EventPipe::hang_up() {
  {
    std::lock_guard lock(mutex_);
    gone_ = true;
  }
  done_writing_.notify_all();
  source_->close();
}

void EventPullers::start(const std::shared_ptr<EventPipe>& pipe, std::function<void()> pull) {
  std::list<Puller> ended;
  {
    std::lock_guard lock(mutex_);
    for (auto it = pullers_.begin(); it != pullers_.end();) {
      const auto next = std::next(it);
      if (*it->done) ended.splice(ended.end(), pullers_, it);
      it = next;
    }
    auto done = std::make_shared<bool>(false);
    pullers_.push_back({pipe, done, std::thread([this, done, pull = std::move(pull)] {
                          pull();
                          std::lock_guard finished(mutex_);
                          *done = true;
                        })});
  }
  for (auto& p : ended) p.thread.join();
}

void EventPullers::close_all() {
  std::lock_guard lock(mutex_);
  for (auto& p : pullers_) p.pipe->source().close();
}

void EventPullers::hang_up_and_join() {
  {
    std::lock_guard lock(mutex_);
    for (auto& p : pullers_) p.pipe->hang_up();
  }
  join_all();
}

void EventPullers::join_all() {
  std::list<Puller> all;
  {
    std::lock_guard lock(mutex_);
    all.swap(pullers_);
  }
  for (auto& p : all)
    if (p.thread.joinable()) p.thread.join();
}

}  // namespace skinspec::api::detail
