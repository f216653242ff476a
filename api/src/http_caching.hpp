#pragma once
// HTTP's caching and compression as the service uses them: entity tags, conditional GETs,
// gzip for large bodies (RFC 9110, 9111).

#include <functional>
#include <string>
#include <string_view>

#include "skinspec/api/body_cache.hpp"
#include "skinspec/api/router.hpp"

namespace skinspec::api::detail {

// Bodies shorter than this are sent as they are: compressing them saves less than it costs.
inline constexpr std::size_t kGzipMinimumBytes = 1024;

// How a stored record that never changes may be cached by clients: for a year, without asking.
inline constexpr std::string_view kImmutable = "public, max-age=31536000, immutable";
// How a record that can change (a measurement gains a newer fit) may be: kept, asked again each
// time with its tag.
inline constexpr std::string_view kRevalidate = "no-cache";

// A strong tag for `body`: its 64-bit FNV-1a digest, quoted.
std::string etag_of(std::string_view body);
// Whether an If-None-Match header's value names `etag` (or is "*"): RFC 9110 13.1.2, weak
// comparison.
bool etag_matches(std::string_view if_none_match, std::string_view etag);
// Whether an Accept-Encoding header's value accepts gzip (not with q=0).
bool accepts_gzip(std::string_view accept_encoding);
// `body` as a gzip stream (zlib, default level).
std::string gzip(std::string_view body);

// `body` with its tag and gzip form (when large enough), ready to keep.
CachedBody cacheable(std::string body);
// `body` with its tag alone, for an answer made for one request.
CachedBody tagged(std::string body);

// The answer to `request` for a cached body: 304 when the client holds it (If-None-Match), else
// 200 with the body, gzip when accepted (compressed now if it was not kept compressed); with its
// ETag, `cache_control` and Vary.
Response cached_response(const Request& request, const CachedBody& cached, std::string_view cache_control,
                         std::string content_type = "application/json");

// The answer to `request` for a stored record that never changes, tagged by what it is rather
// than by its bytes (a map's data, hundreds of MB): 304 when the client holds `etag`, without
// making the body; else 200 with `body()`. With the ETag and `cache_control`.
Response identified_response(const Request& request, const std::string& etag, std::string_view cache_control,
                             std::string content_type, const std::function<std::string()>& body);

// Compresses a large 200 answer in place when the client accepts gzip and nothing else encoded it.
void compress_if_accepted(const Request& request, Response& response);

}  // namespace skinspec::api::detail
