#pragma once
// The instrument of `--model auto` (private to drivers/): each connect() finds out which family
// answers (probe.hpp), and from then on every call goes to that family's driver.

#include <memory>

#include "skinspec/drivers/open_instrument.hpp"

namespace skinspec::drivers::identify {

std::unique_ptr<Instrument> make_auto_instrument(std::unique_ptr<Transport> transport, InstrumentOptions options);

}  // namespace skinspec::drivers::identify
