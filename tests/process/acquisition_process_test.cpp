// Acquisition end to end with real processes on loopback: skinspec-sim as the meter and
// skinspecd driving it through measurement jobs.

#include <gtest/gtest.h>

#include <csignal>
#include <fstream>
#include <sstream>
#include <thread>

#include "skinspec/drivers/pr650.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "support/driver_options.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

const std::string kForearm = std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv";

class AcquisitionTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
};

TEST_F(AcquisitionTest, WhiteThenSampleStoresTheSourceReflectanceAndItsFit) {
  AcquisitionRig rig(rig_options(dir_.path().string(), {}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  // The supervisor connects in the background from the start.
  const std::string initial = http_request(p, "GET", "/api/v1/instrument").json()["state"];
  EXPECT_TRUE(initial == "disconnected" || initial == "connecting" || initial == "connected") << initial;
  const auto s = http_request(p, "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "V1"}}.dump());
  ASSERT_EQ(s.status, 201) << s.body;
  const long long session = s.json()["id"];

  // A sample before any white has nothing to be relative to.
  const auto early = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  EXPECT_EQ(early["state"], "failed");
  EXPECT_EQ(early["error"]["code"], "no_white") << early;

  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}, {"label", "PTFE"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.daemon->err();
  const auto instrument = http_request(p, "GET", "/api/v1/instrument").json();
  EXPECT_EQ(instrument["state"], "connected") << instrument;
  EXPECT_EQ(instrument["serial_number"], "60912345");
  EXPECT_EQ(http_request(p, "GET", "/healthz").json()["instrument"]["state"], "connected");

  const std::vector<std::pair<std::string, std::string>> key = {{"Idempotency-Key", "sample-1"}};
  const auto accepted = submit(p, session, {{"kind", "sample"}}, key);
  const auto again = http_request(p, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements",
                                  json{{"kind", "sample"}}.dump(), key);
  EXPECT_EQ(again.json()["job_id"], accepted["job_id"]);
  const auto job = wait_for_job(p, accepted);
  ASSERT_EQ(job["state"], "succeeded") << job << rig.daemon->err();
  EXPECT_EQ(job["result"]["white_measurement_id"], white["result"]["measurement_id"]);

  const auto m =
      http_request(p, "GET", "/api/v1/measurements/" + std::to_string(job["result"]["measurement_id"].get<long long>()))
          .json();
  EXPECT_EQ(m["kind"], "sample");
  EXPECT_EQ(m["reading_count"], 1);
  const auto expected = first_subject_on_grid(kForearm, 380, 780, 4);
  const auto& stored = m["reflectance"]["values"];
  ASSERT_EQ(stored.size(), expected.size()) << m;
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(stored[i].get<double>(), expected[i], 1e-3 * expected[i] + 1e-6) << "at " << 380 + 4 * i << " nm";

  const auto fit =
      http_request(p, "GET", "/api/v1/fits/" + std::to_string(job["result"]["fit_id"].get<long long>())).json();
  for (const char* field : {"name", "site", "params", "stderr", "rmse", "max_abs_error", "delta_e00_d65", "iterations",
                            "converged", "wavelength_nm", "measured", "fitted"})
    EXPECT_TRUE(fit.contains(field)) << field << " " << fit;
  EXPECT_EQ(fit["site"], "forearm");
  EXPECT_EQ(fit["model"], "extended");  // the session's, by default
  // The same fit as the stateless fitter gives for the stored reflectance.
  const auto direct = http_request(
      p, "POST", "/api/v1/fit",
      json{{"wavelength_nm", m["reflectance"]["wavelength_nm"]}, {"reflectance", stored}, {"site", "forearm"}}.dump());
  ASSERT_EQ(direct.status, 200) << direct.body;
  const json direct_fit = direct.json();
  ASSERT_EQ(fit["params"].size(), direct_fit["params"].size());
  for (const auto& [name, value] : direct_fit["params"].items())
    EXPECT_NEAR(fit["params"][name].get<double>(), value.get<double>(), 1e-9) << name;
  EXPECT_EQ(fit["determination"], direct_fit["determination"]);
}

// One reading with a bad quality code is stored apart with its raw reply and measured again.
TEST_F(AcquisitionTest, ABadQualityCodeIsRejectedKeptAndMeasuredAgain) {
  AcquisitionRig rig(rig_options(dir_.path().string(), {"--fault", "d5:quality=19@2"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "V2");
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();
  const auto job = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(job["state"], "succeeded") << job;
  ASSERT_EQ(job["result"]["rejected_reading_ids"].size(), 1u) << job;
  ASSERT_EQ(job["result"]["warnings"].size(), 1u) << job;
  EXPECT_TRUE(job["result"]["warnings"][0].get<std::string>().starts_with("rejected_reading:")) << job;
  const auto detail = get_json(p, "/api/v1/sessions/" + std::to_string(session));
  EXPECT_EQ(detail["measurements"].size(), 2u) << detail;
  EXPECT_EQ(detail["measurements"][1]["warnings"], job["result"]["warnings"]);
  ASSERT_EQ(detail["rejected_readings"].size(), 1u) << detail;
  const auto& rejected = detail["rejected_readings"][0];
  EXPECT_EQ(rejected["id"], job["result"]["rejected_reading_ids"][0]);
  EXPECT_EQ(rejected["job_id"], job["id"]);
  EXPECT_EQ(rejected["attempt"], 1);
  EXPECT_EQ(rejected["quality"]["code"], 19);
  EXPECT_NE(rejected["reason"].get<std::string>().find("bad_reading"), std::string::npos) << rejected;
  EXPECT_TRUE(rejected["raw_reply_base64"].get<std::string>().starts_with("MTksM")) << rejected;  // "19,0"
  // The stored raw reply is the meter's D5 report with its quality code.
  const auto raw = sqlite_text(rig.db_path(), "SELECT CAST(raw_reply AS TEXT) FROM rejected_readings");
  EXPECT_TRUE(raw.starts_with("19,0")) << raw;
  EXPECT_GT(raw.size(), 1000u);
}

// What the meter says of itself, asked directly once skinspecd has let go of it.
std::expected<drivers::Identity, std::string> identify_directly(unsigned short sim_port) {
  const auto uri = drivers::parse_connection_uri("tcp:127.0.0.1:" + std::to_string(sim_port));
  if (!uri) return std::unexpected(uri.error());
  std::string last_error;
  // The simulator may still be closing the daemon's session: a new client waits its turn.
  for (int attempt = 0; attempt < 20; ++attempt, std::this_thread::sleep_for(100ms)) {
    auto transport = drivers::make_transport(*uri);
    if (!transport) return std::unexpected(transport.error());
    drivers::Pr650 meter(std::move(*transport), fast_driver());
    if (auto contact = meter.connect(); !contact) {
      last_error = contact.error().message;
      continue;
    }
    auto identity = meter.identify();
    if (identity) return *identity;
    last_error = identity.error().message;
  }
  return std::unexpected(last_error);
}

// The instrument's record keeps the spectral configuration the meter reported, as the meter
// reports it when asked again.
TEST_F(AcquisitionTest, TheStoredInstrumentConfigurationIsWhatTheMeterReports) {
  AcquisitionRig rig(rig_options(dir_.path().string(), {}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "V4");
  const auto white = wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();
  const auto m =
      get_json(rig.port, "/api/v1/measurements/" + std::to_string(white["result"]["measurement_id"].get<long long>()));
  ASSERT_TRUE(m["provenance"]["instrument_id"].is_number_integer()) << m;
  const json stored =
      json::parse(sqlite_text(rig.db_path(), "SELECT spectral_configuration FROM instruments WHERE id = " +
                                                 std::to_string(m["provenance"]["instrument_id"].get<long long>())));
  const auto stopped = rig.stop_daemon();  // the simulator serves one client at a time
  ASSERT_TRUE(stopped.exited()) << stopped.describe();

  const auto identity = identify_directly(rig.sim_port);
  ASSERT_TRUE(identity) << identity.error();
  const auto& reported = identity->configuration;
  EXPECT_EQ(stored, (json{{"model", "pr650"},
                          {"reported_model", identity->reported_model},
                          {"family", "pr650"},
                          {"firmware", nullptr},  // the PR-650 has no firmware report
                          {"points", reported.points},
                          {"bandwidth_nm", reported.bandwidth_nm},
                          {"first_nm", reported.first_nm},
                          {"last_nm", reported.last_nm},
                          {"step_nm", reported.step_nm}}));
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT model FROM instruments"), identity->reported_model);
  EXPECT_EQ(stored["points"], m["radiance"]["values"].size());
  EXPECT_EQ(stored["first_nm"], m["radiance"]["wavelength_nm"].front());
  EXPECT_EQ(stored["last_nm"], m["radiance"]["wavelength_nm"].back());
}

TEST_F(AcquisitionTest, QueuedJobsCanBeCancelledAndUnknownOnesAreNotFound) {
  AcquisitionRig rig(rig_options(dir_.path().string(), {}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  EXPECT_EQ(http_request(p, "GET", "/api/v1/jobs/999").status, 404);
  EXPECT_EQ(http_request(p, "POST", "/api/v1/sessions/999/measurements", json{{"kind", "white"}}.dump()).status, 404);
  const long long session =
      http_request(p, "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "V3"}}.dump()).json()["id"];
  EXPECT_EQ(http_request(p, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements",
                         json{{"kind", "dark"}}.dump())
                .status,
            422);
  std::vector<json> jobs;
  for (int i = 0; i < 5; ++i) jobs.push_back(submit(p, session, {{"kind", "white"}, {"count", 3}}));
  const auto cancelled =
      http_request(p, "DELETE", "/api/v1/jobs/" + std::to_string(jobs.back()["job_id"].get<long long>()));
  EXPECT_EQ(cancelled.status == 200 || cancelled.status == 409, true) << cancelled.body;
  for (auto& j : jobs) j = wait_for_job(p, j);
  for (std::size_t i = 0; i + 1 < jobs.size(); ++i) EXPECT_EQ(jobs[i]["state"], "succeeded") << jobs[i];
  if (cancelled.status == 200) {
    EXPECT_EQ(jobs.back()["state"], "cancelled") << jobs.back();
  }
  // Finished in the order submitted.
  for (std::size_t i = 1; i + 1 < jobs.size(); ++i)
    EXPECT_LE(jobs[i - 1]["finished_at"].get<std::string>(), jobs[i]["started_at"].get<std::string>());
}

}  // namespace
}  // namespace skinspec::testing
