#pragma once
// What a measurement job does with readings the meter rejects and with white references that
// may no longer hold: the settings (from skinspecd's flags and config file) and the pure
// functions that word the warnings. No I/O here.

#include <expected>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::daemon {

struct MeasurePolicy {
  // Readings with a bad quality code a job may reject (each stored, then retried) before it
  // fails; 0: the first one fails the job.
  int max_rejected_readings = 2;
  // A sample measured against a white older than this gets a warning.
  double white_max_age_s = 1800;
  // A white whose band-integrated radiance differs from the session's previous white by more
  // than this fraction gets a warning, and so does every sample measured against it.
  double lamp_change_tolerance = 0.05;
};

// An explanation when a setting is out of range.
std::optional<std::string> check(const MeasurePolicy& policy);

// ∫ L(λ) dλ by the trapezoid rule: the lamp's level as a white standard sees it.
double band_integrated(const store::SpectralSamples& radiance);

// Warnings start with a code ("white_stale:", "lamp_changed:", "rejected_reading:") so that a
// program can tell them apart; the rest is for people.
inline constexpr std::string_view kLampChanged = "lamp_changed:";

std::optional<std::string> white_age_warning(const store::Measurement& white, store::Time sample_started,
                                             const MeasurePolicy& policy);
// On a new white against the session's previous one.
std::optional<std::string> lamp_change_warning(const store::Measurement& white, const store::Measurement& previous,
                                               const MeasurePolicy& policy);
// On a sample whose white drew a lamp warning.
std::optional<std::string> inherited_lamp_warning(const store::Measurement& white);

std::string rejection_warning(int attempt, const drivers::InstrumentError& error, store::Id rejected_id);

// The error a job ends with when the meter fails it: the one mapping from the driver's kinds
// to job error codes.
store::JobError job_error(const drivers::InstrumentError& error);
// A job cancelled by request or by the service stopping: the error it ends with (code
// `cancelled` or `stopped`).
store::JobError cancellation(store::JobErrorCode code);
// The state a job ends in with `error`: cancelled for `cancelled` and `stopped`, else failed.
store::JobState ended_state(const store::JobError& error);

}  // namespace skinspec::daemon
