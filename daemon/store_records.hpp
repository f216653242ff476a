#pragma once
// What the meter said, as the store keeps it: the daemon's one place where the drivers' values
// (its identity, its readings, the readings it rejected) become store records. Pure functions;
// the supervisor adds the ids only it knows (session, job, instrument, white).

#include <expected>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::daemon {

// {"model", "reported_model", "family", "firmware", "points", "first_nm", "last_nm", "step_nm",
// "bandwidth_nm"}: which meter it is and the wavelength grid its D120 reply gave.
nlohmann::json spectral_configuration_json(const drivers::Identity& identity);

// The meter as the store knows it: the model it reports, its serial number, the spectral
// configuration it reported, and the --device it was reached by.
store::Instrument instrument_record(const drivers::Identity& identity, const std::string& connection);

// The readings' mean radiance, their standard deviation (more than one reading), quality,
// units, raw replies concatenated, first start and last finish; the caller adds session, kind,
// settings and the rest. An explanation when the readings differ in grid.
std::expected<store::Measurement, std::string> averaged(const std::vector<drivers::Reading>& readings);

// A measurement's settings as JSON text, its provenance: the integration time asked for (0:
// adaptive), the readings asked for and how many were rejected on the way, the meter's averages
// and sync as it did them, extended sensitivity, the aperture (null: as set on the meter), and
// per reading the exposure used ("exposure_used_ms": a fixed one as set, an adaptive one as the
// meter reported it, null where it does not say).
std::string measurement_settings(const std::vector<drivers::Reading>& readings, const drivers::MeasureOptions& asked,
                                 int count, std::size_t rejected_readings);

// A reading the meter returned with a bad quality code: its code, the text its family's table
// gives for it, the reason as the job reports it, and its raw reply.
store::RejectedReading rejected_reading_record(const drivers::InstrumentError& error, drivers::Family family,
                                               int attempt, store::Time measured_at);

}  // namespace skinspec::daemon
