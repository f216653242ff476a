#pragma once
// Which driver speaks to the meter on a connection: the one `--model` names, or with `auto`
// the one the meter's own answers point to (docs/pr6xx-protocol.md, "Identification"). The
// daemon, the CLI and the tests make every instrument here and talk to it only through
// Instrument.

#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "skinspec/drivers/remote_options.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

// A model forced by the user, or none: find out.
struct ModelChoice {
  std::optional<Model> forced;  // nullopt: auto

  // "auto" or a profile id ("pr670"), case-insensitive; the error lists what is accepted.
  static std::expected<ModelChoice, std::string> parse(std::string_view text);
  std::string to_string() const;  // "auto" or the profile id
};

// The exposures a meter may be asked for: the forced model's range, or with auto the widest any
// model has (the driver then holds the identified model to its own before sending anything).
ExposureRange exposure_range(const ModelChoice& choice);

// Every driver's options, each family taking its own.
struct InstrumentOptions {
  DriverOptions pr650;
  RemoteOptions remote;
};

// The options a connection URI implies: its terminator, its line rate (a serial port's baud;
// a TCP serial server relays the meter's own), and `pacing_ms` for the newer meters.
InstrumentOptions instrument_options_for(const ConnectionUri& uri);

// The driver for the meter behind `transport`. Nothing is sent until connect(). With a forced
// model it is that family's driver; connect() fails with `identification` when the meter says
// it is another known model, or answers as another family. With auto, every connect() first
// finds out which family answers (the PR-650 inside its power-on window, then the newer
// meters, then the PR-650 again), and from then on the instrument behaves as that family's
// driver, which takes the link over as identification left it. A model skinspec does not know
// is an `identification` error under auto; forced, it is measured as the forced model, and
// its identity has no model and an `unknown-model:` warning.
std::unique_ptr<Instrument> make_instrument(std::unique_ptr<Transport> transport, ModelChoice choice,
                                            InstrumentOptions options);

}  // namespace skinspec::drivers
