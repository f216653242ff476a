#pragma once
// Values kept by key within a byte budget: the least recently used go first once the cache holds
// more. Safe to share between threads.

#include <cstddef>
#include <functional>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

namespace skinspec::api {

template <typename Value>
class LruCache {
 public:
  // `bytes_of`: what a value counts against the budget.
  LruCache(std::size_t max_bytes, std::function<std::size_t(const Value&)> bytes_of)
      : max_bytes_(max_bytes), bytes_of_(std::move(bytes_of)) {}

  std::optional<Value> find(const std::string& key) {
    const std::lock_guard lock(mutex_);
    const auto it = index_.find(key);
    if (it == index_.end()) return std::nullopt;
    entries_.splice(entries_.begin(), entries_, it->second);
    return it->second->second;
  }

  // Keeps `value` under `key`, most recent first; a value larger than the budget is not kept.
  void put(const std::string& key, Value value) {
    const std::size_t bytes = bytes_of_(value) + key.size();
    if (bytes > max_bytes_) return;
    const std::lock_guard lock(mutex_);
    if (const auto it = index_.find(key); it != index_.end()) {
      bytes_ -= bytes_of_(it->second->second) + key.size();
      entries_.erase(it->second);
      index_.erase(it);
    }
    bytes_ += bytes;
    entries_.emplace_front(key, std::move(value));
    index_[key] = entries_.begin();
    while (bytes_ > max_bytes_) {
      bytes_ -= bytes_of_(entries_.back().second) + entries_.back().first.size();
      index_.erase(entries_.back().first);
      entries_.pop_back();
    }
  }

  std::size_t size() const {
    const std::lock_guard lock(mutex_);
    return entries_.size();
  }

 private:
  using Entry = std::pair<std::string, Value>;
  mutable std::mutex mutex_;
  std::list<Entry> entries_;  // most recently used first
  std::unordered_map<std::string, typename std::list<Entry>::iterator> index_;
  std::size_t bytes_ = 0;
  const std::size_t max_bytes_;
  const std::function<std::size_t(const Value&)> bytes_of_;
};

}  // namespace skinspec::api
