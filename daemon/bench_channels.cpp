#include "bench_channels.hpp"

#include <charconv>

#include <nlohmann/json.hpp>

namespace skinspec::daemon {

using nlohmann::json;

namespace {
constexpr std::string_view kCancelPrefix = "cancel:";
}

std::string cancel_notice(store::Id job_id) { return std::string(kCancelPrefix) + std::to_string(job_id); }

std::optional<store::Id> parse_cancel_notice(std::string_view text) {
  if (!text.starts_with(kCancelPrefix)) return std::nullopt;
  text.remove_prefix(kCancelPrefix.size());
  store::Id id = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), id);
  if (error != std::errc{} || end != text.data() + text.size() || id <= 0) return std::nullopt;
  return id;
}

std::string job_event_json(const JobEvent& event) {
  json out = {{"bench", event.bench}, {"job", event.job_id}, {"ended", !event.progress}};
  if (event.progress) {
    out["position"] = event.progress->position;
    out["phase"] = std::string(api::to_string(event.progress->phase));
    out["readings_done"] = event.progress->readings_done;
    out["readings_total"] = event.progress->readings_total;
  }
  return out.dump();
}

std::optional<JobEvent> parse_job_event(std::string_view text) {
  const json in = json::parse(text, nullptr, false);
  if (!in.is_object()) return std::nullopt;
  try {
    JobEvent event;
    event.bench = in.at("bench").get<std::string>();
    event.job_id = in.at("job").get<store::Id>();
    if (in.at("ended").get<bool>()) return event;
    const auto phase = api::parse_job_phase(in.at("phase").get<std::string>());
    if (!phase) return std::nullopt;
    event.progress = api::JobProgress{in.at("position").get<int>(), *phase, in.at("readings_done").get<int>(),
                                      in.at("readings_total").get<int>(), std::nullopt};
    return event;
  } catch (const json::exception&) {
    return std::nullopt;
  }
}

}  // namespace skinspec::daemon
