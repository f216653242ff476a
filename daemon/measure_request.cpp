#include "measure_request.hpp"

#include <nlohmann/json.hpp>

namespace skinspec::daemon {

using nlohmann::json;

std::string measure_request_json(const api::MeasureRequest& request) {
  return json{{"kind", std::string(store::to_string(request.kind))},
              {"count", request.count},
              {"label", request.label},
              {"integration_ms", request.integration_ms}}
      .dump();
}

std::optional<api::MeasureRequest> parse_measure_request(const std::string& text) {
  const json in = json::parse(text, nullptr, false);
  if (!in.is_object()) return std::nullopt;
  api::MeasureRequest out;
  try {
    const auto kind = store::parse_measurement_kind(in.at("kind").get<std::string>());
    if (!kind) return std::nullopt;
    out.kind = *kind;
    out.count = in.at("count").get<int>();
    out.label = in.at("label").get<std::string>();
    out.integration_ms = in.at("integration_ms").get<int>();
  } catch (const json::exception&) {
    return std::nullopt;
  }
  return out;
}

}  // namespace skinspec::daemon
