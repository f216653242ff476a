#include "skinspec/store/types.hpp"

#include <algorithm>

namespace skinspec::store {

namespace {

template <typename E, std::size_t N>
std::optional<E> lookup(const std::array<std::pair<E, std::string_view>, N>& names, std::string_view text) {
  const auto found = std::ranges::find(names, text, &std::pair<E, std::string_view>::second);
  if (found == names.end()) return std::nullopt;
  return found->first;
}

template <typename E, std::size_t N>
std::string_view name_of(const std::array<std::pair<E, std::string_view>, N>& names, E value) {
  const auto found = std::ranges::find(names, value, &std::pair<E, std::string_view>::first);
  return found == names.end() ? std::string_view("unknown") : found->second;
}

constexpr std::array<std::pair<SessionState, std::string_view>, 4> kSessionStates = {{
    {SessionState::open, "open"},
    {SessionState::complete, "complete"},
    {SessionState::interrupted, "interrupted"},
    {SessionState::aborted, "aborted"},
}};

constexpr std::array<std::pair<MeasurementKind, std::string_view>, 4> kMeasurementKinds = {{
    {MeasurementKind::white, "white"},
    {MeasurementKind::sample, "sample"},
    {MeasurementKind::dark, "dark"},
    {MeasurementKind::imported, "imported"},
}};

constexpr std::array<std::pair<BenchState, std::string_view>, 3> kBenchStates = {{
    {BenchState::running, "running"},
    {BenchState::stopped, "stopped"},
    {BenchState::silent, "silent"},
}};

constexpr std::array<std::pair<JobState, std::string_view>, 5> kJobStates = {{
    {JobState::queued, "queued"},
    {JobState::running, "running"},
    {JobState::succeeded, "succeeded"},
    {JobState::failed, "failed"},
    {JobState::cancelled, "cancelled"},
}};

constexpr std::array<std::pair<JobErrorCode, std::string_view>, 17> kJobErrorCodes = {{
    {JobErrorCode::cancelled, "cancelled"},
    {JobErrorCode::stopped, "stopped"},
    {JobErrorCode::interrupted, "interrupted"},
    {JobErrorCode::no_contact, "no_contact"},
    {JobErrorCode::lost, "lost"},
    {JobErrorCode::protocol, "protocol"},
    {JobErrorCode::bad_reading, "bad_reading"},
    {JobErrorCode::rejected, "rejected"},
    {JobErrorCode::transport, "transport"},
    {JobErrorCode::identification, "identification"},
    {JobErrorCode::no_white, "no_white"},
    {JobErrorCode::white_mismatch, "white_mismatch"},
    {JobErrorCode::white_dark, "white_dark"},
    {JobErrorCode::store, "store"},
    {JobErrorCode::storage_full, "storage_full"},
    {JobErrorCode::bad_file, "bad_file"},
    {JobErrorCode::internal, "internal"},
}};

constexpr std::array<std::pair<StoreError::Kind, std::string_view>, 13> kErrorKinds = {{
    {StoreError::Kind::invalid_argument, "invalid_argument"},
    {StoreError::Kind::not_found, "not_found"},
    {StoreError::Kind::conflict, "conflict"},
    {StoreError::Kind::newer_schema, "newer_schema"},
    {StoreError::Kind::older_schema, "older_schema"},
    {StoreError::Kind::corrupt, "corrupt"},
    {StoreError::Kind::read_only, "read_only"},
    {StoreError::Kind::full, "full"},
    {StoreError::Kind::busy, "busy"},
    {StoreError::Kind::io, "io"},
    {StoreError::Kind::internal, "internal"},
    {StoreError::Kind::unreachable, "unreachable"},
    {StoreError::Kind::access_denied, "access_denied"},
}};

}  // namespace

std::string_view to_string(StoreError::Kind kind) { return name_of(kErrorKinds, kind); }

bool is_bad_target(StoreError::Kind kind) {
  using Kind = StoreError::Kind;
  return kind != Kind::io && kind != Kind::full && kind != Kind::internal;
}
std::string_view to_string(SessionState state) { return name_of(kSessionStates, state); }
std::string_view to_string(MeasurementKind kind) { return name_of(kMeasurementKinds, kind); }
std::string_view to_string(JobState state) { return name_of(kJobStates, state); }
std::string_view to_string(JobErrorCode code) { return name_of(kJobErrorCodes, code); }

std::optional<SessionState> parse_session_state(std::string_view text) { return lookup(kSessionStates, text); }
std::optional<MeasurementKind> parse_measurement_kind(std::string_view text) { return lookup(kMeasurementKinds, text); }
std::optional<JobState> parse_job_state(std::string_view text) { return lookup(kJobStates, text); }
std::optional<JobErrorCode> parse_job_error_code(std::string_view text) { return lookup(kJobErrorCodes, text); }

std::span<const std::pair<SessionState, std::string_view>> session_state_names() { return kSessionStates; }
std::span<const std::pair<MeasurementKind, std::string_view>> measurement_kind_names() { return kMeasurementKinds; }
std::span<const std::pair<JobState, std::string_view>> job_state_names() { return kJobStates; }
std::span<const std::pair<BenchState, std::string_view>> bench_state_names() { return kBenchStates; }
std::string_view to_string(BenchState state) { return name_of(kBenchStates, state); }
std::span<const std::pair<JobErrorCode, std::string_view>> job_error_code_names() { return kJobErrorCodes; }

bool bench_running(const Bench& bench, Time now) {
  return !bench.stopped_at && now - bench.heartbeat_at <= bench.lease;
}

BenchState bench_state(const Bench& bench, Time now) {
  if (bench.stopped_at) return BenchState::stopped;
  return bench_running(bench, now) ? BenchState::running : BenchState::silent;
}

JobErrorCode job_error_code_of(StoreError::Kind kind) {
  return kind == StoreError::Kind::full ? JobErrorCode::storage_full : JobErrorCode::store;
}

}  // namespace skinspec::store
