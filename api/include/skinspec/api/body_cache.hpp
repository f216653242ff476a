#pragma once
// Answers that never change once made (a stored fit), kept as the bytes sent: the JSON, its
// gzip form and its entity tag, so that a repeated request costs no SQL and no JSON building.

#include <memory>
#include <string>

#include "skinspec/api/lru_cache.hpp"

namespace skinspec::api {

struct CachedBody {
  std::string body;
  std::string gzip;  // empty when the body is too small to be worth compressing
  std::string etag;  // quoted, as the ETag header gives it
};

class BodyCache : public LruCache<std::shared_ptr<const CachedBody>> {
 public:
  explicit BodyCache(std::size_t max_bytes = 64u << 20)
      : LruCache(max_bytes, [](const std::shared_ptr<const CachedBody>& b) {
          return b->body.size() + b->gzip.size() + b->etag.size();
        }) {}
};

}  // namespace skinspec::api
