#include "identity_json.hpp"

namespace skinspec::drivers {

using nlohmann::json;

namespace {

json text_or_null(const std::string& text) { return text.empty() ? json(nullptr) : json(text); }

}  // namespace

json identity_json(const Identity& identity) {
  const Grid& grid = identity.grid;
  return {
      {"model", identity.model ? json(profile(*identity.model).id) : json(nullptr)},
      {"reported_model", text_or_null(identity.reported_model)},
      {"family", to_string(identity.family)},
      {"serial_number", text_or_null(identity.serial_number)},
      {"firmware", text_or_null(identity.firmware)},
      {"grid",
       {{"first_nm", grid.first_nm}, {"last_nm", grid.last_nm}, {"step_nm", grid.step_nm}, {"points", grid.points}}},
      {"warnings", identity.warnings}};
}

json no_identity_json() {
  json out = identity_json(Identity{});
  for (auto& [key, value] : out.items()) value = key == "warnings" ? json::array() : json(nullptr);
  return out;
}

}  // namespace skinspec::drivers
