#include "store_records.hpp"

#include <cmath>

#include "identity_json.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

json spectral_configuration_json(const drivers::Identity& identity) {
  const json shown = drivers::identity_json(identity);
  json configuration = {{"model", shown["model"]},
                        {"reported_model", shown["reported_model"]},
                        {"family", shown["family"]},
                        {"firmware", shown["firmware"]},
                        {"bandwidth_nm", identity.configuration.bandwidth_nm}};
  configuration.update(shown["grid"]);
  return configuration;
}

store::Instrument instrument_record(const drivers::Identity& identity, const std::string& connection) {
  store::Instrument instrument;
  instrument.model = identity.reported_model;
  instrument.serial_number = identity.serial_number;
  instrument.spectral_configuration = spectral_configuration_json(identity).dump();
  instrument.connection = connection;
  return instrument;
}

std::expected<store::Measurement, std::string> averaged(const std::vector<drivers::Reading>& readings) {
  if (readings.empty()) return std::unexpected("no readings");
  const auto& first = readings.front();
  const std::size_t n = first.radiance.size();
  const double count = static_cast<double>(readings.size());
  store::Measurement m;
  m.quality_code = first.quality_code;
  m.quality = first.quality;
  m.units = first.units;
  m.reading_count = static_cast<int>(readings.size());
  m.radiance.wavelength_nm = first.wavelength_nm;
  m.radiance.values.assign(n, 0.0);
  for (const auto& r : readings) {
    if (r.wavelength_nm != first.wavelength_nm || r.radiance.size() != n)
      return std::unexpected("readings on different grids");
    for (std::size_t i = 0; i < n; ++i) m.radiance.values[i] += r.radiance[i] / count;
    m.raw_reply += r.raw_reply;
  }
  if (readings.size() > 1) {
    m.radiance_sd.wavelength_nm = first.wavelength_nm;
    m.radiance_sd.values.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      double sum = 0;
      for (const auto& r : readings)
        sum += (r.radiance[i] - m.radiance.values[i]) * (r.radiance[i] - m.radiance.values[i]);
      m.radiance_sd.values[i] = std::sqrt(sum / (count - 1));
    }
  }
  m.started_at = to_store_time(first.started);
  m.finished_at = to_store_time(readings.back().finished);
  return m;
}

std::string measurement_settings(const std::vector<drivers::Reading>& readings, const drivers::MeasureOptions& asked,
                                 int count, std::size_t rejected_readings) {
  json settings = {{"integration_ms", asked.integration_ms},
                   {"count", count},
                   {"rejected_readings", rejected_readings},
                   {"extended_sensitivity", asked.extended_sensitivity},
                   {"aperture", asked.aperture.empty() ? json(nullptr) : json(asked.aperture)}};
  if (!readings.empty()) {
    settings["averages"] = readings.front().averages;
    settings["sync"] = readings.front().sync;
  }
  json exposures = json::array();
  for (const auto& r : readings) {
    if (r.integration_ms != 0) exposures.push_back(r.integration_ms);
    else exposures.push_back(r.exposure_used_ms ? json(*r.exposure_used_ms) : json(nullptr));
  }
  settings["exposure_used_ms"] = exposures;
  return settings.dump();
}

store::RejectedReading rejected_reading_record(const drivers::InstrumentError& error, drivers::Family family,
                                               int attempt, store::Time measured_at) {
  store::RejectedReading r;
  r.attempt = attempt;
  r.quality_code = error.quality_code;
  r.quality = family == drivers::Family::pr650 ? drivers::pr650::quality_message(error.quality_code)
                                               : drivers::pr6xx::error_message(error.quality_code);
  r.reason = describe(error);
  r.raw_reply = error.raw_reply;
  r.measured_at = measured_at;
  return r;
}

}  // namespace skinspec::daemon
