#pragma once
// What every Photo Research meter offers a program, whatever its family: connect, identify,
// measure, cancel, disconnect. The PR-650 (pr650.hpp), the PR-655/670/680 (pr6xx.hpp) and the
// PR-7xx (pr7xx.hpp) implement it; their errors, identities and readings share these types.

#include <array>
#include <chrono>
#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers {

struct InstrumentError {
  enum class Kind {
    no_contact,   // never answered: outside its power-on window, off, or wrong port
    lost,         // answered before, now silent or the link failed
    protocol,     // a reply that cannot be what the meter sends, even after asking again
    bad_reading,  // the meter measured but its quality code makes the reading unusable
    rejected,     // the meter refused a setup
    cancelled,
    transport,       // the port or host could not be opened
    identification,  // something answered, but not as the meter that was asked for (or any skinspec knows)
  };
  Kind kind;
  std::string message;
  int quality_code = -1;  // for bad_reading: the PR-650's quality code, or a newer meter's negative status
  std::string raw_reply;  // the meter's bytes, when there were any (for the record)
};

std::string_view to_string(InstrumentError::Kind kind);

// What check() returns when the meter on the link answers with another serial number than the
// one identified: `lost`, as the meter that was identified is gone.
InstrumentError another_meter_answers(std::string_view serial_now, std::string_view serial_before);

struct Identity {
  std::string serial_number;                   // D110
  pr650::SpectralConfiguration configuration;  // D120, as the PR-650 driver has always given it
  std::optional<Model> model;                  // resolved; nullopt: a model skinspec does not know
  Family family = Family::pr650;
  std::string reported_model;         // D111 verbatim ("PR-730/735"); "PR-650" for the PR-650, which has no D111
  std::string firmware;               // D114 ("2.22D"); empty for the PR-650
  Grid grid;                          // D120's wavelength grid, which every spectrum must lie on
  std::vector<std::string> warnings;  // how the meter was found, when that matters (a glued banner, ...)
};

struct MeasureOptions {
  int integration_ms = 0;  // within the model's range, or 0 = adaptive
  int averages = 1;        // 1-99
  // automatic: measure the flicker first; frequency: sync to `sync_hz`.
  enum class Sync { off, automatic, frequency } sync = Sync::off;
  bool adjust_integration = false;  // double on low light, halve on overload (fixed time only)
  bool si_units = true;
  // With Sync::frequency: within the model's sync range (the PR-650 40-250 Hz; the newer
  // meters 20-400 Hz, whole hertz).
  double sync_hz = 0;
  // The newer meters with `caps.sensitivity`: the longer exposure range (SH1). Others refuse it.
  bool extended_sensitivity = false;
  // The newer meters with `caps.aperture`: an aperture by the name the meter lists (D117),
  // such as "1/2 deg"; empty: as the meter is. Others refuse it.
  std::string aperture = {};
};

struct Reading {
  int quality_code = 0;
  std::string quality;          // the code's message
  int units_code = 0;           // D5 units: 0 radiance, 1 irradiance, 2 uncalibrated
  std::string units;            // "W/(sr m2 nm)" ...
  std::string luminance_units;  // "cd/m2" or "fL" ...
  int integration_ms = 0;       // as asked (0 = adaptive)
  // After an adaptive measurement, the exposure the meter says it chose (D13); nullopt after a
  // fixed one (integration_ms) and where the meter does not say (the PR-650, a firmware without D13).
  std::optional<int> exposure_used_ms;
  int averages = 1;
  std::string sync;                   // "off", "last measured frequency (60.02 Hz)", "60 Hz (user)" ...
  std::vector<double> wavelength_nm;  // the meter's native grid (D120)
  std::vector<double> radiance;       // per nm, as the meter prints it
  double integrated = 0;
  double luminance = 0, x = 0, y = 0;  // from report 1
  std::array<double, 3> xyz{};         // from report 2
  std::string serial_number;
  std::chrono::system_clock::time_point started, finished;
  std::string raw_reply;  // the spectral, D1 and D2 replies as received
  int attempts = 1;       // measurements made for this reading
  // What whoever keeps the reading should know about how it was taken, each starting with a
  // code: "remeasured:" when a measurement never answered and was made again, "sync-off:" when
  // the meter could not sync and measured again without, "exposure:" when the exposure changed.
  std::vector<std::string> warnings;
};

class Instrument {
 public:
  virtual ~Instrument() = default;

  // Opens the port and makes first contact (for the newer meters: enters remote mode).
  virtual std::expected<void, InstrumentError> connect() = 0;
  // Leaves remote mode where the meter has one, and closes the port.
  virtual void disconnect() = 0;
  virtual bool connected() const = 0;
  // Whether the link is known to be dead without a word on it; false during a call.
  virtual bool link_closed() = 0;
  // Replies (whole or not) received since the driver was made: comparing two counts tells a
  // failure on the first command from one after the meter had answered.
  virtual std::uint64_t replies_received() const = 0;

  virtual std::expected<Identity, InstrumentError> identify() = 0;
  // Whether the identified meter still answers, with as little traffic as the family allows
  // (a newer meter's commands go out one paced byte at a time): for noticing, while idle, a
  // meter switched off or swapped. A different serial number than identify() found is `lost`.
  virtual std::expected<void, InstrumentError> check() = 0;
  virtual std::expected<Reading, InstrumentError> measure(const MeasureOptions& options) = 0;
  // Ends a running call with `cancelled`. Any thread.
  virtual void cancel() = 0;

  virtual std::string describe() const = 0;
  virtual const std::string& serial_number() const = 0;

  // What the driver found on this connection that the meter's firmware lacks, and does without
  // ("m5-fallback: ..."), each once; empty for a meter that knows every command. Any thread.
  virtual std::vector<std::string> firmware_warnings() const { return {}; }
  // The apertures the identified meter lists (D117), by its names, for MeasureOptions::aperture;
  // read once per connection. Empty for a model without apertures to choose.
  virtual std::expected<std::vector<std::string>, InstrumentError> apertures() { return std::vector<std::string>{}; }
  // The longest one measure() with `options` may take while the meter answers in time: the
  // deadlines of its commands, each sized to the command (measurements by their exposures and
  // averages, replies by their length at the link's rate). For the time left of a job.
  virtual std::chrono::milliseconds reading_time(const MeasureOptions& options) const = 0;
};

}  // namespace skinspec::drivers
