#pragma once
// What the router needs from acquisition: the instrument's state, and a queue of measurement
// jobs. The daemon implements it with the drivers, the fitter and the store; the router knows
// only this interface, so that api/ does not depend on drivers/.

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

#include <nlohmann/json.hpp>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/job_watch.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api {

// How a measurement syncs to the light: not at all, to the flicker the meter measures first, or
// to a frequency given in hertz. As JSON: "off", "auto" or the frequency, a number.
struct SyncRequest {
  enum class Mode { off, automatic, frequency } mode = Mode::off;
  double hz = 0;  // with frequency
  friend bool operator==(const SyncRequest&, const SyncRequest&) = default;
};
nlohmann::json sync_json(const SyncRequest& sync);
// nullopt for anything but "off", "auto" or a finite frequency above 0 (the meter's range is
// the acquisition's to hold it to).
std::optional<SyncRequest> parse_sync_request(const nlohmann::json& value);

// The kinds a measurement job may take: dark readings and imports are not asked of the meter.
inline constexpr std::array kMeasurementJobKinds = {store::MeasurementKind::white, store::MeasurementKind::sample};

struct MeasureRequest {
  store::MeasurementKind kind = store::MeasurementKind::sample;
  int count = 1;  // readings averaged into one measurement (1-100)
  std::string label;
  int integration_ms = 0;  // 0: adaptive
  // The meter's own settings, each held to what the identified meter takes when the job is
  // posted (GET /api/v1/instrument's "capabilities").
  int averages = 1;  // measurements the meter averages into each reading
  SyncRequest sync;
  bool extended_sensitivity = false;  // the longer exposure range of the models that have it
  std::string aperture;               // by the name the meter lists (D117); empty: as the meter is
};

// What the instrument is doing (GET /api/v1/instrument's "state").
enum class InstrumentState { disconnected, connecting, connected, measuring, lost };
std::string_view to_string(InstrumentState state);
std::optional<InstrumentState> parse_instrument_state(std::string_view text);
std::span<const std::pair<InstrumentState, std::string_view>> instrument_state_names();

class Acquisition {
 public:
  virtual ~Acquisition() = default;
  // What knows the live progress of the measurement jobs it runs.
  virtual const JobWatch& jobs() const = 0;
  // {"device", "port", "state" (an InstrumentState), "since",
  //  "last_error", "serial_number", "attempts", "next_attempt_in_ms", "queued", ...}
  virtual nlohmann::json instrument_status() const = 0;
  // The serial ports and USB serial adapters present: {"ports": [...]} (GET /api/v1/ports).
  virtual nlohmann::json ports() const = 0;
  // Queues a measurement of an open session; an idempotency key seen before returns that job.
  virtual std::expected<store::CreatedJob, ApiError> submit(store::Id session_id, const MeasureRequest& request,
                                                            const std::string& idempotency_key) = 0;
  // Cancels a queued or running job; the job as it is afterwards.
  virtual std::expected<store::Job, ApiError> cancel(store::Id job_id) = 0;
};

// A time as every answer of the API shows it: RFC 3339, UTC, with microseconds.
std::string api_time(store::Time time);

// A job as the API shows it, with `position` (1 or more while queued, 0 while running, null
// once finished), `progress` and `error` ({code, message} or null): its live progress and
// state when given and the record has not finished, else what the store says (phase done,
// fraction 1 when it succeeded).
nlohmann::json job_json(const store::Job& job, const std::optional<JobProgress>& live);

// Job `id` as the API shows it now: its live progress read first, then its record, so that
// the two agree (`watch`, what runs jobs of its kind, may be null).
store::Result<nlohmann::json> current_job_json(const store::Store& db, const JobWatch* watch, store::Id id);

}  // namespace skinspec::api
