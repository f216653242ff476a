// The web console's files: GET / is the page, GET /ui/NAME its scripts and style. They hold no
// data (everything comes through the API with the user's token), so they need no token, and
// they stay out of the OpenAPI document, which describes the API.

#include "web.hpp"

#include "web_assets.hpp"

namespace skinspec::api {

std::optional<Response> console_file(const std::string& method, std::string_view path) {
  constexpr std::string_view kPrefix = "/ui/";
  std::string_view name;
  if (path == "/") name = "index.html";
  else if (path.substr(0, kPrefix.size()) == kPrefix) name = path.substr(kPrefix.size());
  else return std::nullopt;
  if (method != "GET") return std::nullopt;  // the route table answers 404/405
  const auto asset = web_asset(name);
  if (!asset) return std::nullopt;
  Response r{200, std::string(asset->content_type), std::string(asset->bytes), {}};
  // The files change only with the program; the page itself is always revalidated so that an
  // upgraded daemon is picked up at the next load.
  r.headers.emplace_back("Cache-Control", "no-cache");
  r.headers.emplace_back("X-Content-Type-Options", "nosniff");
  r.headers.emplace_back(
      "Content-Security-Policy",
      "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; script-src 'self'; connect-src 'self'");
  return r;
}

}  // namespace skinspec::api
