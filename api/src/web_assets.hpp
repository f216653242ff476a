#pragma once
// The web console's files (api/web/), compiled into the program by api/web/embed.cmake.

#include <optional>
#include <string_view>

namespace skinspec::api {

struct WebAsset {
  std::string_view name;  // "index.html", "app.js", ...
  std::string_view content_type;
  std::string_view bytes;
};

std::optional<WebAsset> web_asset(std::string_view name);

}  // namespace skinspec::api
