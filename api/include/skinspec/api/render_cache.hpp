#pragma once
// The rendered images the service has made, kept by their parameters within a byte budget.

#include <string>

#include "skinspec/api/lru_cache.hpp"

namespace skinspec::api {

class RenderCache : public LruCache<std::string> {
 public:
  explicit RenderCache(std::size_t max_bytes = 64u << 20)
      : LruCache(max_bytes, [](const std::string& png) { return png.size(); }) {}
};

}  // namespace skinspec::api
