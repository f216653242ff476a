#include "measure_request.hpp"

#include <nlohmann/json.hpp>

namespace skinspec::daemon {

using nlohmann::json;

std::string measure_request_json(const api::MeasureRequest& request) {
  return json{{"kind", std::string(store::to_string(request.kind))},
              {"count", request.count},
              {"label", request.label},
              {"integration_ms", request.integration_ms},
              {"averages", request.averages},
              {"sync", api::sync_json(request.sync)},
              {"extended_sensitivity", request.extended_sensitivity},
              {"aperture", request.aperture.empty() ? json(nullptr) : json(request.aperture)}}
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
    // Absent from the jobs of versions before the meter's settings were asked for.
    out.averages = in.value("averages", 1);
    if (const auto sync = in.find("sync"); sync != in.end()) {
      const auto parsed = api::parse_sync_request(*sync);
      if (!parsed) return std::nullopt;
      out.sync = *parsed;
    }
    out.extended_sensitivity = in.value("extended_sensitivity", false);
    if (const auto aperture = in.find("aperture"); aperture != in.end() && !aperture->is_null())
      out.aperture = aperture->get<std::string>();
  } catch (const json::exception&) {
    return std::nullopt;
  }
  return out;
}

}  // namespace skinspec::daemon
