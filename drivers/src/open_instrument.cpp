#include "skinspec/drivers/open_instrument.hpp"

#include <fmt/format.h>

#include "skinspec/drivers/pr6xx.hpp"
#include "skinspec/drivers/pr7xx.hpp"

namespace skinspec::drivers {

std::expected<ModelChoice, std::string> ModelChoice::parse(std::string_view text) {
  std::string lower;
  for (const char c : text) lower += static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  if (lower == "auto") return ModelChoice{};
  if (auto model = model_from_id(lower)) return ModelChoice{*model};
  std::string known = "auto";
  for (const auto& p : all_profiles()) known += fmt::format(", {}", p.id);
  return std::unexpected(fmt::format("unknown model '{}' (one of: {})", text, known));
}

std::string ModelChoice::to_string() const { return forced ? std::string(profile(*forced).id) : "auto"; }

InstrumentOptions instrument_options_for(const ConnectionUri& uri) {
  InstrumentOptions options;
  options.pr650 = driver_options_for(uri);
  options.remote.style.terminator = '\r';
  if (uri.scheme != ConnectionUri::Scheme::tcp && uri.baud > 0)
    options.remote.timing.line_bytes_per_second = uri.baud / 10.0;
  return options;
}

std::unique_ptr<Instrument> make_instrument(std::unique_ptr<Transport> transport, ModelChoice choice,
                                            InstrumentOptions options) {
  const Model model = choice.forced.value_or(Model::pr650);
  switch (profile(model).family) {
    case Family::pr650:
      return std::make_unique<Pr650>(std::move(transport), options.pr650);
    case Family::pr6xx:
      return std::make_unique<Pr6xx>(model, std::move(transport), options.remote);
    case Family::pr7xx:
      return std::make_unique<Pr7xx>(model, std::move(transport), options.remote);
  }
  return nullptr;
}

}  // namespace skinspec::drivers
