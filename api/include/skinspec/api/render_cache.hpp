#pragma once
// The rendered images the service has made, kept by their parameters: the least recently used
// go first once the cache holds more than its byte budget. Safe to share between threads.

#include <cstddef>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

namespace skinspec::api {

class RenderCache {
 public:
  explicit RenderCache(std::size_t max_bytes = 64u << 20) : max_bytes_(max_bytes) {}

  std::optional<std::string> find(const std::string& key);
  // Keeps `png` under `key`, most recent first; an image larger than the budget is not kept.
  void put(const std::string& key, std::string png);

  std::size_t size() const;

 private:
  using Entry = std::pair<std::string, std::string>;  // key, PNG bytes
  mutable std::mutex mutex_;
  std::list<Entry> entries_;  // most recently used first
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  std::size_t bytes_ = 0;
  std::size_t max_bytes_;
};

}  // namespace skinspec::api
