#pragma once
// skinspecd daemons as benches of one PostgreSQL database, each with a skinspec-sim meter of its
// own, for the process tests of benches and of the database server's faults.

#include <chrono>
#include <cstdio>
#include <ctime>
#include <stdexcept>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {

struct Bench {
  ScratchDirectory dir;
  std::unique_ptr<AcquisitionRig> rig;

  // skinspecd as bench `name` of the database `uri`, its meter at `time_scale` (0: at once;
  // 0.05: a reading in about 0.35 s).
  Bench(const std::string& uri, const std::string& name, const std::string& time_scale,
        std::vector<std::string> daemon_args = {}, std::vector<std::string> daemon_environment = {}) {
    daemon_args.insert(daemon_args.end(), {"--bench", name});
    auto options = rig_options(dir.path().string(), {"--time-scale", time_scale}, daemon_args);
    options.db = uri;
    options.daemon_environment = std::move(daemon_environment);
    rig = std::make_unique<AcquisitionRig>(options);
  }
  unsigned short port() const { return rig->port; }
};

// Bench `name` as GET /api/v1/benches through `port` shows it; null when it is not listed.
inline nlohmann::json bench_named(unsigned short port, const std::string& name) {
  const auto listed = get_json(port, "/api/v1/benches");
  for (const auto& b : listed["benches"])
    if (b["name"] == name) return b;
  return nullptr;
}

// Whether `holds()` became true within `limit`, asked every 20 ms.
inline bool eventually(const std::function<bool()>& holds, std::chrono::milliseconds limit) {
  for (const auto until = std::chrono::steady_clock::now() + limit; std::chrono::steady_clock::now() < until;) {
    if (holds()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return holds();
}

// An API time, "2026-12-02T16:10:09.355436Z".
inline std::chrono::system_clock::time_point time_of(const std::string& text) {
  std::tm parts{};
  int micros = 0;
  if (std::sscanf(text.c_str(), "%d-%d-%dT%d:%d:%d.%dZ", &parts.tm_year, &parts.tm_mon, &parts.tm_mday, &parts.tm_hour,
                  &parts.tm_min, &parts.tm_sec, &micros) != 7)
    throw std::runtime_error("not an API time: " + text);
  parts.tm_year -= 1900;
  parts.tm_mon -= 1;
  return std::chrono::system_clock::from_time_t(timegm(&parts)) + std::chrono::microseconds(micros);
}

}  // namespace skinspec::testing
