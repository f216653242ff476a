#pragma once
// The PR-730/735/740/745/788: a measurement is triggered with T and polled with P until done;
// V gives its outcome and D5 its spectrum. cancel() aborts it on the meter with A. A meter
// busy with a measurement that was not aborted is waited for.

#include "skinspec/drivers/remote_meter.hpp"

namespace skinspec::drivers {

namespace remote {
struct Rule;
}

class Pr7xx final : public RemoteMeter {
 public:
  // `model` must be of family pr7xx (std::invalid_argument otherwise).
  Pr7xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options = {});

 private:
  std::expected<Spectrum, InstrumentError> take_spectrum(int exposure_ms, int cycles) override;
  std::expected<void, InstrumentError> wait_while_busy(std::string_view command) override;
  std::expected<int, InstrumentError> poll_until_done(std::chrono::milliseconds limit);
  std::expected<void, InstrumentError> abort_measurement();
  remote::Rule line_rule() const;
};

}  // namespace skinspec::drivers
