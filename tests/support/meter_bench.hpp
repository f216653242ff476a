#pragma once
// What the driver tests of every family share: a white standard on a model's own grid, the
// simulated meter's options for a model, a transport that keeps what the driver wrote, and a
// simulated meter with the instrument make_instrument gives for it.

#include <algorithm>
#include <functional>
#include <memory>
#include <optional>
#include <mutex>
#include <string>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/drivers/transport.hpp"
#include "support/simulator_rig.hpp"

namespace skinspec::testing {

// A transport that passes everything through and keeps what the driver wrote, so that a test
// can see the commands on the wire (the simulator logs only modes, faults and measurements).
class WireTap final : public drivers::Transport {
 public:
  explicit WireTap(std::unique_ptr<drivers::Transport> inner) : inner_(std::move(inner)) {}
  std::expected<void, drivers::TransportError> open() override { return inner_->open(); }
  void close() override { inner_->close(); }
  bool is_open() const override { return inner_->is_open(); }
  std::expected<void, drivers::TransportError> flush_input() override { return inner_->flush_input(); }
  std::expected<void, drivers::TransportError> write(std::string_view bytes, drivers::Deadline deadline) override {
    {
      std::lock_guard lock(*mutex_);
      *written_ += bytes;
    }
    return inner_->write(bytes, deadline);
  }
  std::expected<std::size_t, drivers::TransportError> read(char* buffer, std::size_t size,
                                                           drivers::Deadline deadline) override {
    return inner_->read(buffer, size, deadline);
  }
  std::expected<void, drivers::TransportError> set_modem_lines(bool dtr, bool rts) override {
    return inner_->set_modem_lines(dtr, rts);
  }
  void interrupt() override { inner_->interrupt(); }
  void clear_interrupt() override { inner_->clear_interrupt(); }
  std::string describe() const override { return inner_->describe(); }

  // What was written, readable after the driver (and this tap) is gone.
  std::function<std::string()> written() const {
    return [mutex = mutex_, written = written_] {
      std::lock_guard lock(*mutex);
      return *written;
    };
  }

 private:
  std::unique_ptr<drivers::Transport> inner_;
  std::shared_ptr<std::mutex> mutex_ = std::make_shared<std::mutex>();
  std::shared_ptr<std::string> written_ = std::make_shared<std::string>();
};

// A white standard under D65 on `model`'s grid; `flicker_hz` 0 is a steady lamp.
inline simulator::Scene white_on(drivers::Model model, double flicker_hz = 60) {
  const auto grid = simulator::wavelengths(*drivers::profile(model).simulator_grid);
  auto colour = simulator::ColourData::load(directory_reader(SKINSPEC_TEST_DATA_DIR), grid);
  const simulator::Lamp lamp{"D65", colour->d65, 100};
  simulator::Scene scene = simulator::scene_under_lamp("white standard", *Spectrum::create({380, 780}, {0.99, 0.99}),
                                                       lamp, colour->observer);
  scene.flicker_hz = flicker_hz;
  return scene;
}

inline simulator::Synthesis synthesis_of(drivers::Model model, const simulator::Scene& scene) {
  const auto grid = simulator::wavelengths(*drivers::profile(model).simulator_grid);
  auto colour = simulator::ColourData::load(directory_reader(SKINSPEC_TEST_DATA_DIR), grid);
  return simulator::Synthesis{colour->observer, {scene}};
}

// A simulated `model` that does not wait, with `faults` (the simulator's fault grammar).
inline simulator::MeterOptions meter_options(drivers::Model model, std::vector<std::string> faults = {}) {
  simulator::MeterOptions options = fast_meter();
  options.model = model;
  options.faults = *simulator::FaultPlan::parse(faults);
  return options;
}

inline drivers::InstrumentOptions fast_options() {
  drivers::InstrumentOptions options;
  options.pr650 = fast_driver();
  options.remote = fast_remote();
  return options;
}

// A simulated meter of `model` and the instrument make_instrument gives for `choice` on the
// other end of the link; `before` may talk to the meter first, as another program would.
struct InstrumentBench {
  InstrumentBench(drivers::Model model, drivers::ModelChoice choice = {},
                  std::optional<simulator::MeterOptions> meter = {},
                  const std::function<void(drivers::Transport&)>& before = {},
                  drivers::InstrumentOptions options = fast_options(), double flicker_hz = 60)
      : scene(white_on(model, flicker_hz)),
        rig(synthesis_of(model, scene), meter ? std::move(*meter) : meter_options(model)) {
    if (before) before(*rig.host());
    auto tap = std::make_unique<WireTap>(rig.take_host());
    written = tap->written();
    instrument = drivers::make_instrument(std::move(tap), choice, options);
  }
  std::size_t logged(std::string_view line) const {
    const auto log = rig.log();
    return static_cast<std::size_t>(std::ranges::count(log, std::string(line)));
  }
  simulator::Scene scene;
  MeterRig rig;
  std::function<std::string()> written;
  std::unique_ptr<drivers::Instrument> instrument;
};

}  // namespace skinspec::testing
