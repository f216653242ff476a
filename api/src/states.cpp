// The names of the instrument's states, of a job's kinds and phases, and of a measurement's sync
// modes, as the API shows them: the one mapping each way.

#include <algorithm>
#include <array>
#include <cmath>

#include "skinspec/api/acquisition.hpp"

namespace skinspec::api {

namespace {

constexpr std::array<std::pair<InstrumentState, std::string_view>, 5> kInstrumentStates = {{
    {InstrumentState::disconnected, "disconnected"},
    {InstrumentState::connecting, "connecting"},
    {InstrumentState::connected, "connected"},
    {InstrumentState::measuring, "measuring"},
    {InstrumentState::lost, "lost"},
}};

constexpr std::array<std::pair<JobPhase, std::string_view>, 7> kJobPhases = {{
    {JobPhase::queued, "queued"},
    {JobPhase::connecting, "connecting"},
    {JobPhase::measuring, "measuring"},
    {JobPhase::reading, "reading"},
    {JobPhase::fitting, "fitting"},
    {JobPhase::storing, "storing"},
    {JobPhase::done, "done"},
}};

// A frequency has no name: it is the number.
constexpr std::array<std::pair<SyncRequest::Mode, std::string_view>, 2> kSyncModes = {{
    {SyncRequest::Mode::off, "off"},
    {SyncRequest::Mode::automatic, "auto"},
}};

constexpr std::array<std::pair<JobKind, std::string_view>, 4> kJobKinds = {{
    {JobKind::measure, "measure"},
    {JobKind::import, "import"},
    {JobKind::refit, "refit"},
    {JobKind::map, "map"},
}};

template <typename E>
std::string_view name_in(std::span<const std::pair<E, std::string_view>> names, E value) {
  const auto found = std::ranges::find(names, value, &std::pair<E, std::string_view>::first);
  return found == names.end() ? std::string_view("unknown") : found->second;
}

template <typename E>
std::optional<E> value_in(std::span<const std::pair<E, std::string_view>> names, std::string_view text) {
  const auto found = std::ranges::find(names, text, &std::pair<E, std::string_view>::second);
  if (found == names.end()) return std::nullopt;
  return found->first;
}

}  // namespace

std::span<const std::pair<InstrumentState, std::string_view>> instrument_state_names() { return kInstrumentStates; }
std::string_view to_string(InstrumentState state) { return name_in(instrument_state_names(), state); }
std::optional<InstrumentState> parse_instrument_state(std::string_view text) {
  return value_in(instrument_state_names(), text);
}

nlohmann::json sync_json(const SyncRequest& sync) {
  if (sync.mode == SyncRequest::Mode::frequency) return sync.hz;
  return std::string(name_in<SyncRequest::Mode>(kSyncModes, sync.mode));
}

std::optional<SyncRequest> parse_sync_request(const nlohmann::json& value) {
  if (value.is_string()) {
    const auto mode = value_in<SyncRequest::Mode>(kSyncModes, value.get<std::string>());
    if (!mode) return std::nullopt;
    return SyncRequest{*mode, 0};
  }
  if (!value.is_number()) return std::nullopt;
  const double hz = value.get<double>();
  if (!std::isfinite(hz) || hz <= 0) return std::nullopt;
  return SyncRequest{SyncRequest::Mode::frequency, hz};
}

std::span<const std::pair<JobPhase, std::string_view>> job_phase_names() { return kJobPhases; }
std::string_view to_string(JobPhase phase) { return name_in(job_phase_names(), phase); }
std::optional<JobPhase> parse_job_phase(std::string_view text) { return value_in(job_phase_names(), text); }

std::span<const std::pair<JobKind, std::string_view>> job_kind_names() { return kJobKinds; }
std::string_view to_string(JobKind kind) { return name_in(job_kind_names(), kind); }
std::optional<JobKind> parse_job_kind(std::string_view text) { return value_in(job_kind_names(), text); }

}  // namespace skinspec::api
