// From file names and options to a simulated meter.

#include <fmt/format.h>

#include "data_dir.hpp"
#include "skinspec/simulator/simulator.hpp"

namespace skinspec::simulator {

namespace {

constexpr double kWhiteStandardReflectance = 0.99;

std::expected<Lamp, std::string> lamp_of(const SimulatorConfig& config, const ColourData& colour) {
  if (!(config.white_luminance > 0))
    return std::unexpected(fmt::format("white luminance {} cd/m2 is not positive", config.white_luminance));
  if (config.illuminant == "D65" || config.illuminant == "A") {
    auto power = colour.illuminant(config.illuminant);
    if (!power) return std::unexpected(power.error());
    return Lamp{config.illuminant, std::move(*power), config.white_luminance};
  }
  auto bytes = read_file(config.illuminant);
  if (!bytes) return std::unexpected(fmt::format("illuminant: {} (use D65, A, or a spectra CSV file)", bytes.error()));
  auto power = illuminant_from_csv(*bytes, config.illuminant);
  if (!power) return std::unexpected(power.error());
  return Lamp{config.illuminant, std::move(*power), config.white_luminance};
}

std::expected<void, std::string> add_reflectance(std::vector<Scene>& scenes, const std::string& file, const Lamp& lamp,
                                                 const Observer& observer) {
  auto bytes = read_file(file);
  if (!bytes) return std::unexpected(bytes.error());
  auto more = reflectance_scenes(*bytes, file, lamp, observer);
  if (!more) return std::unexpected(more.error());
  scenes.insert(scenes.end(), more->begin(), more->end());
  return {};
}

// Scenes on the model's grid: each source resampled from its own wavelengths.
std::expected<Synthesis, std::string> synthesis_of(const SimulatorConfig& config, drivers::Model model) {
  const std::vector<double> grid = wavelengths(*drivers::profile(model).simulator_grid);
  auto colour = ColourData::load(directory_reader(find_data_dir()), grid);
  if (!colour) return std::unexpected(fmt::format("colour tables: {}", colour.error()));
  auto lamp = lamp_of(config, *colour);
  if (!lamp) return std::unexpected(lamp.error());
  Synthesis synthesis{colour->observer, {}};
  if (!config.white_file.empty())
    if (auto added = add_reflectance(synthesis.scenes, config.white_file, *lamp, colour->observer); !added)
      return std::unexpected(added.error());
  for (const auto& file : config.reflectance_files)
    if (auto added = add_reflectance(synthesis.scenes, file, *lamp, colour->observer); !added)
      return std::unexpected(added.error());
  if (!config.radiance_file.empty()) {
    auto bytes = read_file(config.radiance_file);
    if (!bytes) return std::unexpected(bytes.error());
    auto scenes = radiance_scenes(*bytes, config.radiance_file, grid);
    if (!scenes) return std::unexpected(scenes.error());
    synthesis.scenes.insert(synthesis.scenes.end(), scenes->begin(), scenes->end());
  }
  if (synthesis.scenes.empty()) {
    auto flat = Spectrum::create({grid.front(), grid.back()}, {kWhiteStandardReflectance, kWhiteStandardReflectance});
    synthesis.scenes.push_back(
        scene_under_lamp(fmt::format("white standard under {}", lamp->name), *flat, *lamp, colour->observer));
  }
  for (auto& scene : synthesis.scenes) scene.flicker_hz = config.flicker_hz;
  return synthesis;
}

}  // namespace

std::expected<std::unique_ptr<SimulatedMeter>, std::string> make_simulated_meter(const SimulatorConfig& config) {
  const int sources = !config.replay_file.empty() + !config.radiance_file.empty() + !config.reflectance_files.empty();
  if (sources > 1) return std::unexpected("give one source of readings: a replay, a radiance or reflectance files");
  if (!config.replay_file.empty() && !config.white_file.empty())
    return std::unexpected("a white standard goes with reflectance files, not with a replay");
  if (config.meter.time_scale < 0)
    return std::unexpected(fmt::format("time scale {} is negative", config.meter.time_scale));

  MeterOptions options = config.meter;
  auto plan = FaultPlan::parse(config.faults, config.fault_rate, config.seed, config.fault_gap);
  if (!plan) return std::unexpected(plan.error());
  options.faults = std::move(*plan);
  options.seed = config.seed;

  if (!config.replay_file.empty()) {
    auto bytes = read_file(config.replay_file);
    if (!bytes) return std::unexpected(bytes.error());
    auto recording = parse_recording(*bytes, config.replay_file);
    if (!recording) return std::unexpected(recording.error());
    const drivers::Model recorded = recording->header.model;
    if (config.model && *config.model != recorded)
      return std::unexpected(fmt::format("{} is a recording of a {}, not of a {}", config.replay_file,
                                         drivers::profile(recorded).name, drivers::profile(*config.model).name));
    options.model = recorded;
    return std::make_unique<SimulatedMeter>(std::move(*recording), std::move(options));
  }
  options.model = config.model.value_or(drivers::Model::pr650);
  auto synthesis = synthesis_of(config, options.model);
  if (!synthesis) return std::unexpected(synthesis.error());
  return std::make_unique<SimulatedMeter>(std::move(*synthesis), std::move(options));
}

}  // namespace skinspec::simulator
