#include "skinspec/drivers/open_instrument.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "identify/auto_instrument.hpp"
#include "identify/family_driver.hpp"
#include "skinspec/drivers/pr6xx.hpp"
#include "skinspec/drivers/pr7xx.hpp"

namespace skinspec::drivers {

std::expected<ModelChoice, std::string> ModelChoice::parse(std::string_view text) {
  const bool is_auto = std::ranges::equal(text, std::string_view("auto"),
                                          [](char a, char b) { return (a | 0x20) == b; });  // ASCII, any case
  if (is_auto) return ModelChoice{};
  if (auto model = model_from_id(text)) return ModelChoice{*model};  // case-insensitive itself
  std::string known = "auto";
  for (const auto& p : all_profiles()) known += fmt::format(", {}", p.id);
  return std::unexpected(fmt::format("unknown model '{}' (one of: {})", text, known));
}

std::string ModelChoice::to_string() const { return forced ? std::string(profile(*forced).id) : "auto"; }

ExposureRange exposure_range(const ModelChoice& choice) {
  if (choice.forced) return profile(*choice.forced).exposure;
  ExposureRange widest{std::numeric_limits<int>::max(), 0, 0};
  for (const auto& p : all_profiles()) {
    widest.min_ms = std::min(widest.min_ms, p.exposure.min_ms);
    widest.max_ms = std::max(widest.max_ms, p.exposure.max_ms);
    widest.max_extended_ms = std::max(widest.max_extended_ms, p.exposure.max_extended_ms);
  }
  return widest;
}

InstrumentOptions instrument_options_for(const ConnectionUri& uri) {
  InstrumentOptions options;
  options.pr650 = driver_options_for(uri);
  if (uri.terminator) options.remote.style.terminator = *uri.terminator;
  if (uri.pacing_ms) options.remote.pacing = std::chrono::milliseconds(*uri.pacing_ms);
  if (uri.scheme != ConnectionUri::Scheme::tcp && uri.baud > 0)
    options.remote.timing.line_bytes_per_second = uri.baud / 10.0;
  return options;
}

namespace identify {

std::unique_ptr<RemoteMeter> make_remote_meter(Model model, std::unique_ptr<Transport> transport,
                                               const RemoteOptions& options) {
  if (profile(model).family == Family::pr7xx) return std::make_unique<Pr7xx>(model, std::move(transport), options);
  return std::make_unique<Pr6xx>(model, std::move(transport), options);
}

std::unique_ptr<Instrument> make_family_driver(Model model, std::unique_ptr<Transport> transport,
                                               const InstrumentOptions& options) {
  if (profile(model).family == Family::pr650) return std::make_unique<Pr650>(std::move(transport), options.pr650);
  return make_remote_meter(model, std::move(transport), options.remote);
}

}  // namespace identify

std::unique_ptr<Instrument> make_instrument(std::unique_ptr<Transport> transport, ModelChoice choice,
                                            InstrumentOptions options) {
  if (!choice.forced) return identify::make_auto_instrument(std::move(transport), std::move(options));
  return identify::make_family_driver(*choice.forced, std::move(transport), options);
}

}  // namespace skinspec::drivers
