#include "http_caching.hpp"

#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <stdexcept>

#include <boost/beast/core/string.hpp>
#include <fmt/format.h>

#include "text.hpp"

namespace skinspec::api::detail {

namespace {

// Calls `each` with every comma-separated member of a header's value, trimmed.
template <typename F>
void for_each_member(std::string_view list, F&& each) {
  while (!list.empty()) {
    const auto comma = list.find(',');
    each(trimmed(list.substr(0, comma)));
    if (comma == std::string_view::npos) break;
    list.remove_prefix(comma + 1);
  }
}

bool iequals(std::string_view a, std::string_view b) {
  return boost::beast::iequals(boost::beast::string_view(a.data(), a.size()),
                               boost::beast::string_view(b.data(), b.size()));
}

std::string header(const Request& request, const std::string& name) {
  const auto it = request.headers.find(name);
  return it == request.headers.end() ? std::string() : it->second;
}

bool compressible(const std::string& content_type) {
  return content_type.starts_with("application/json") || content_type.starts_with("text/");
}

}  // namespace

std::string etag_of(std::string_view body) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const unsigned char c : body) hash = (hash ^ c) * 0x100000001b3ull;
  return fmt::format("\"{:016x}\"", hash);
}

bool etag_matches(std::string_view if_none_match, std::string_view etag) {
  bool matched = false;
  for_each_member(if_none_match, [&](std::string_view tag) {
    if (tag.starts_with("W/")) tag.remove_prefix(2);
    matched = matched || tag == "*" || tag == etag;
  });
  return matched;
}

bool accepts_gzip(std::string_view accept_encoding) {
  bool accepted = false;
  for_each_member(accept_encoding, [&](std::string_view member) {
    const auto semicolon = member.find(';');
    const auto coding = trimmed(member.substr(0, semicolon));
    if (!iequals(coding, "gzip") && !iequals(coding, "x-gzip")) return;
    accepted = true;
    if (semicolon == std::string_view::npos) return;
    const auto parameter = trimmed(member.substr(semicolon + 1));
    if (parameter.size() > 2 && (parameter[0] == 'q' || parameter[0] == 'Q') && parameter[1] == '=') {
      double q = 1;
      std::from_chars(parameter.data() + 2, parameter.data() + parameter.size(), q);
      accepted = q > 0;  // q=0: "not acceptable"
    }
  });
  return accepted;
}

std::string gzip(std::string_view body) {
  z_stream stream{};
  // 15 window bits + 16: a gzip header and trailer rather than zlib's.
  if (deflateInit2(&stream, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("zlib could not start compressing");
  std::string out(deflateBound(&stream, static_cast<uLong>(body.size())), '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(body.data()));
  stream.avail_in = static_cast<uInt>(body.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&stream, Z_FINISH);
  out.resize(stream.total_out);
  deflateEnd(&stream);
  if (status != Z_STREAM_END) throw std::runtime_error("zlib could not compress a body");
  return out;
}

CachedBody cacheable(std::string body) {
  CachedBody cached;
  cached.etag = etag_of(body);
  if (body.size() >= kGzipMinimumBytes) cached.gzip = gzip(body);
  cached.body = std::move(body);
  return cached;
}

CachedBody tagged(std::string body) {
  CachedBody out;
  out.etag = etag_of(body);
  out.body = std::move(body);
  return out;
}

Response cached_response(const Request& request, const CachedBody& cached, std::string_view cache_control,
                         std::string content_type) {
  Response r;
  r.content_type = std::move(content_type);
  r.headers = {{"ETag", cached.etag}, {"Cache-Control", std::string(cache_control)}, {"Vary", "Accept-Encoding"}};
  if (etag_matches(header(request, "if-none-match"), cached.etag)) {
    r.status = 304;
    return r;
  }
  if (cached.body.size() >= kGzipMinimumBytes && compressible(r.content_type) &&
      accepts_gzip(header(request, "accept-encoding"))) {
    r.body = cached.gzip.empty() ? gzip(cached.body) : cached.gzip;
    r.headers.emplace_back("Content-Encoding", "gzip");
  } else {
    r.body = cached.body;
  }
  return r;
}

Response identified_response(const Request& request, const std::string& etag, std::string_view cache_control,
                             std::string content_type, const std::function<std::string()>& body) {
  Response r{200, std::move(content_type), "", {{"ETag", etag}, {"Cache-Control", std::string(cache_control)}}};
  if (etag_matches(header(request, "if-none-match"), etag)) {
    r.status = 304;
    return r;
  }
  r.body = body();
  return r;
}

void compress_if_accepted(const Request& request, Response& response) {
  if (response.status != 200 || response.events || response.body.size() < kGzipMinimumBytes ||
      !compressible(response.content_type))
    return;
  for (const auto& [name, value] : response.headers)
    if (iequals(name, "Content-Encoding") || iequals(name, "Vary")) return;  // negotiated already
  response.headers.emplace_back("Vary", "Accept-Encoding");
  if (!accepts_gzip(header(request, "accept-encoding"))) return;
  response.body = gzip(response.body);
  response.headers.emplace_back("Content-Encoding", "gzip");
}

}  // namespace skinspec::api::detail
