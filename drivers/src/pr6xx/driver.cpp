#include "skinspec/drivers/pr6xx.hpp"

namespace skinspec::drivers {

Pr6xx::Pr6xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options)
    : RemoteMeter(Family::pr6xx, model, std::move(transport), options) {}

std::expected<RemoteMeter::Spectrum, InstrumentError> Pr6xx::take_spectrum(int exposure_ms, int cycles) {
  return measure_with_m5(exposure_ms, cycles);
}

}  // namespace skinspec::drivers
