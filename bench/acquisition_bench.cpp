// The daemon's overhead per measurement: from the last byte of the meter's reply to the fit
// being stored and visible through the API. Goal: median <= 10 ms.
//
// Real skinspecd and skinspec-sim processes on loopback, the simulator at time scale 0. Sample
// jobs are submitted one at a time; each job is polled (GET /api/v1/jobs/{id}, kept-alive
// connection, no pause) until it has succeeded, then its fit is read (GET /api/v1/fits/{id}).
// The overhead is the wall-clock time at which the fit was read minus the job's
// result.timing.reply_received_at_us (when the driver had the meter's last reply); both clocks
// are the same machine's. The polling's own round trips are included, so this is an upper bound.
//
// Run: build/release/bin/acquisition_bench [JOBS]   (default 200)

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace {

using nlohmann::json;
using namespace skinspec::testing;
using skinspec::client::HttpConnection;

std::int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Sample {
  double overhead_ms = 0, derive_ms = 0, fit_ms = 0;
};

double percentile(std::vector<double> values, double p) {
  std::ranges::sort(values);
  const auto index = static_cast<std::size_t>(p * static_cast<double>(values.size() - 1) + 0.5);
  return values[index];
}

void report(const char* name, const std::vector<Sample>& samples, double Sample::* field) {
  std::vector<double> values;
  for (const auto& s : samples) values.push_back(s.*field);
  std::printf("%-38s median %7.3f ms   p95 %7.3f ms   max %7.3f ms\n", name, percentile(values, 0.5),
              percentile(values, 0.95), percentile(values, 1.0));
}

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "acquisition_bench: %s\n", message.c_str());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  const int jobs = argc > 1 ? std::atoi(argv[1]) : 200;
  if (jobs < 1) die("JOBS must be a positive number");
  ScratchDirectory dir;
  RigOptions options;
  options.bin_dir = SKINSPEC_BENCH_BIN_DIR;
  options.data_dir = SKINSPEC_BENCH_DATA_DIR;
  options.work_dir = dir.path().string();
  options.sim_args = {"--quiet"};
  options.daemon_args = {"--log-level", "warn"};
  AcquisitionRig rig(options);
  if (!rig.ready()) die("the rig did not start:\n" + rig.logs());
  const auto session = new_session(rig.port, "bench");
  if (wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}))["state"] != "succeeded")
    die("the white failed");

  HttpConnection api(rig.port);
  std::vector<Sample> samples;
  for (int i = 0; i < jobs; ++i) {
    const auto accepted = submit(rig.port, session, {{"kind", "sample"}});
    if (!accepted.contains("job_id")) die("refused: " + accepted.dump());
    const std::string job_path = fmt::format("/api/v1/jobs/{}", accepted["job_id"].get<long long>());
    json job;
    do job = api.request("GET", job_path).json();
    while (job.value("state", "") == "queued" || job.value("state", "") == "running");
    if (job["state"] != "succeeded" || job["result"]["fit_id"].is_null()) die("job failed: " + job.dump());
    if (api.request("GET", fmt::format("/api/v1/fits/{}", job["result"]["fit_id"].get<long long>())).status != 200)
      die("the fit is not visible");
    const auto visible = now_us();
    const auto& timing = job["result"]["timing"];
    samples.push_back({static_cast<double>(visible - timing["reply_received_at_us"].get<std::int64_t>()) / 1000.0,
                       timing["derive_ms"].get<double>(), timing["fit_ms"].get<double>()});
  }
  std::printf("%d sample jobs, one at a time (skinspec-sim at time scale 0, loopback)\n", jobs);
  report("reply -> fit visible through the API", samples, &Sample::overhead_ms);
  report("  of which reflectance and fit", samples, &Sample::derive_ms);
  report("  of which the fit", samples, &Sample::fit_ms);
  std::printf("goal: median <= 10 ms: %s\n", percentile(
                                                 [&] {
                                                   std::vector<double> v;
                                                   for (const auto& s : samples) v.push_back(s.overhead_ms);
                                                   return v;
                                                 }(),
                                                 0.5) <= 10
                                                 ? "met"
                                                 : "NOT met");
  return 0;
}
