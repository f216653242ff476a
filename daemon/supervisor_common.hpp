#pragma once
// Small helpers shared by the supervisor's source files.

#include <chrono>
#include <string>
#include <string_view>
#include <thread>

#include <spdlog/spdlog.h>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::daemon {

inline store::Time to_store_time(std::chrono::system_clock::time_point t) {
  return std::chrono::floor<std::chrono::microseconds>(t);
}

inline std::string describe(const drivers::InstrumentError& e) {
  return std::string(drivers::to_string(e.kind)) + ": " + e.message;
}

// `write()`, asked again twice (after 50 ms, then 250 ms) while the store refuses it for a
// reason that may pass (busy, an I/O error); each refusal logged.
template <typename Write>
auto with_retries(std::string_view what, store::Id job_id, Write write) {
  using Kind = store::StoreError::Kind;
  auto result = write();
  for (const auto wait : {std::chrono::milliseconds(50), std::chrono::milliseconds(250)}) {
    if (result) break;
    const auto kind = result.error().kind;
    if (kind != Kind::busy && kind != Kind::io && kind != Kind::internal) break;
    spdlog::warn("event=store_retry what={} job={} kind={} error=\"{}\"", what, job_id, store::to_string(kind),
                 result.error().message);
    std::this_thread::sleep_for(wait);
    result = write();
  }
  return result;
}

// Whether the store refused for want of its database, which comes back: a server restarting,
// failing over or out of reach, or read-only for a while.
inline bool database_away(store::StoreError::Kind kind) {
  return kind == store::StoreError::Kind::unreachable || kind == store::StoreError::Kind::read_only;
}

// `write()`, for a job's end, which holds what the meter measured: as with_retries, then, while
// the database is away, again every half second until it is back or `give_up()` (the daemon
// stopping), so an outage the service outlives costs no job its readings (docs/store.md,
// "Outages").
template <typename Write, typename GiveUp>
auto outlasting_outages(std::string_view what, store::Id job_id, Write write, GiveUp give_up) {
  auto result = with_retries(what, job_id, write);
  if (result || !database_away(result.error().kind)) return result;
  spdlog::warn("event=store_waiting what={} job={} kind={} error=\"{}\"", what, job_id,
               store::to_string(result.error().kind), result.error().message);
  while (!result && database_away(result.error().kind) && !give_up()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    result = write();
  }
  if (result) spdlog::info("event=store_back what={} job={}", what, job_id);
  return result;
}

}  // namespace skinspec::daemon
