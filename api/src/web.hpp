#pragma once
// The web console's files served by the router (api/web/, compiled in).

#include <optional>
#include <string>
#include <string_view>

#include "skinspec/api/router.hpp"

namespace skinspec::api {

// The console file for a GET of `path` ("/" or "/ui/NAME"), or nothing when it is not one.
std::optional<Response> console_file(const std::string& method, std::string_view path);

}  // namespace skinspec::api
