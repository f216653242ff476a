#pragma once
// The driver of a model's family (private to drivers/): one place that maps a family to its
// driver class, for make_instrument and for identification.

#include <memory>

#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/drivers/remote_meter.hpp"

namespace skinspec::drivers::identify {

// Pr6xx or Pr7xx; `model` must be a newer meter's.
std::unique_ptr<RemoteMeter> make_remote_meter(Model model, std::unique_ptr<Transport> transport,
                                               const RemoteOptions& options);
// Any family's driver.
std::unique_ptr<Instrument> make_family_driver(Model model, std::unique_ptr<Transport> transport,
                                               const InstrumentOptions& options);

}  // namespace skinspec::drivers::identify
