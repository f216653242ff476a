#pragma once
// The PR-655, PR-670 and PR-680: a measurement is M5, whose reply is the spectrum. There is no
// abort: a cancelled M5's reply is drained before the next command.

#include "skinspec/drivers/remote_meter.hpp"

namespace skinspec::drivers {

class Pr6xx final : public RemoteMeter {
 public:
  // `model` must be of family pr6xx (std::invalid_argument otherwise).
  Pr6xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options = {});

 private:
  std::expected<Spectrum, InstrumentError> take_spectrum(int exposure_ms, int cycles) override;
};

}  // namespace skinspec::drivers
