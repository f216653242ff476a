// The newer meters end to end with real processes on loopback: skinspecd and `skinspec measure`
// driving `skinspec-sim --model ...`. A whole session on the PR-670's 2 nm and the PR-730's 1 nm
// grid stores the source's reflectance and the meter as it identified itself; SIGTERM to either
// program leaves remote mode (Q) whether the meter is idle or measuring; `skinspec measure
// --json` names the meter of each family.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <sstream>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/process.hpp"
#include "support/service_processes.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

const std::string kForearm = std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv";
const std::string kSkinspec = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec";
constexpr std::string_view kQuitLogged = "command Q: remote mode left";

// What skinspecd and skinspec are told of the meter: nothing (--model auto), so that every test
// also shows the meter identified by its own answers.
std::string model_flag(const std::string& /*model*/) { return "auto"; }

// A simulated model, what it should say of itself, and the serial number it is given.
struct Meter {
  std::string model;           // --model of skinspec-sim
  std::string reported_model;  // its D111
  std::string family;
  std::string serial;
  int first_nm, last_nm, step_nm, points;
};

const Meter kPr650{"pr650", "PR-650", "pr650", "60954321", 380, 780, 4, 101};
const Meter kPr670{"pr670", "PR-670", "pr6xx", "67012345", 380, 780, 2, 201};
const Meter kPr730{"pr730", "PR-730/735", "pr7xx", "73012345", 380, 780, 1, 401};

std::ostream& operator<<(std::ostream& out, const Meter& meter) { return out << meter.model; }
std::string model_name(const ::testing::TestParamInfo<Meter>& param) { return param.param.model; }

json grid_of(const Meter& m) {
  return {{"first_nm", m.first_nm}, {"last_nm", m.last_nm}, {"step_nm", m.step_nm}, {"points", m.points}};
}

// skinspec-sim as `meter` (time scale 0 unless given) and skinspecd told its model.
RigOptions rig_for(const ScratchDirectory& dir, const Meter& meter, const std::string& time_scale = "0") {
  return rig_options(dir.path().string(),
                     {"--model", meter.model, "--serial", meter.serial, "--time-scale", time_scale},
                     {"--model", model_flag(meter.model)});
}

long long id_of(const json& job, const char* key) { return job["result"][key].get<long long>(); }

// Polls GET /api/v1/instrument until the meter is connected (or 30 s pass); the last answer.
json when_connected(unsigned short port) {
  json status;
  for (auto until = std::chrono::steady_clock::now() + 30s; std::chrono::steady_clock::now() < until;) {
    status = get_json(port, "/api/v1/instrument");
    if (status.value("state", "") == "connected") break;
    std::this_thread::sleep_for(50ms);
  }
  return status;
}

// One simulated meter per test, in a scratch directory of its own.
class MeterTest : public ::testing::TestWithParam<Meter> {
 protected:
  ScratchDirectory dir_;
};
using Pr6xxSessionTest = MeterTest;
using Pr6xxStopTest = MeterTest;
using MeasureCommandTest = MeterTest;

// White, then samples: the stored reflectance is the simulator's source on the meter's own
// grid, it is fitted, and the instrument is stored and shown as the meter identified itself.
TEST_P(Pr6xxSessionTest, AWholeSessionStoresTheSourceReflectanceOnTheMetersGrid) {
  const Meter& meter = GetParam();
  AcquisitionRig rig(rig_for(dir_, meter));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const long long session = new_session(p, "N1");
  ASSERT_NE(session, 0);
  const auto white = wait_for_job(p, submit(p, session, {{"kind", "white"}}));
  ASSERT_EQ(white["state"], "succeeded") << white << rig.logs();

  const json instrument = get_json(p, "/api/v1/instrument");
  EXPECT_EQ(instrument["state"], "connected") << instrument;
  EXPECT_EQ(instrument["model"], meter.model) << instrument;
  EXPECT_EQ(instrument["reported_model"], meter.reported_model);
  EXPECT_EQ(instrument["family"], meter.family);
  EXPECT_EQ(instrument["serial_number"], meter.serial);
  EXPECT_TRUE(instrument["firmware"].is_string()) << instrument;
  EXPECT_EQ(instrument["grid"], grid_of(meter));
  EXPECT_EQ(instrument["warnings"], json::array());
  const json documented = get_json(p, "/openapi.json")["components"]["schemas"]["Instrument"]["properties"];
  for (const auto& [key, value] : instrument.items()) EXPECT_TRUE(documented.contains(key)) << key;

  const auto job = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
  EXPECT_EQ(job["result"]["warnings"], json::array()) << job;
  const auto m = get_json(p, "/api/v1/measurements/" + std::to_string(id_of(job, "measurement_id")));
  ASSERT_EQ(m["radiance"]["wavelength_nm"].size(), static_cast<std::size_t>(meter.points)) << m;
  EXPECT_EQ(m["radiance"]["wavelength_nm"].front(), meter.first_nm);
  EXPECT_EQ(m["radiance"]["wavelength_nm"][1], meter.first_nm + meter.step_nm);
  EXPECT_EQ(m["radiance"]["wavelength_nm"].back(), meter.last_nm);
  EXPECT_EQ(m["reflectance"]["wavelength_nm"], m["radiance"]["wavelength_nm"]);
  const auto expected = first_subject_on_grid(kForearm, meter.first_nm, meter.last_nm, meter.step_nm);
  const auto& stored = m["reflectance"]["values"];
  ASSERT_EQ(stored.size(), expected.size()) << m;
  // Sample and white are each printed with four significant digits: 1e-3 of the value at most.
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(stored[i].get<double>(), expected[i], 1e-3 * expected[i] + 1e-6)
        << "at " << meter.first_nm + meter.step_nm * static_cast<int>(i) << " nm";

  ASSERT_TRUE(job["result"]["fit_id"].is_number_integer()) << job;
  const auto fit = get_json(p, "/api/v1/fits/" + std::to_string(id_of(job, "fit_id")));
  EXPECT_EQ(fit["wavelength_nm"].size(), static_cast<std::size_t>(meter.points)) << fit;
  EXPECT_EQ(fit["measured"], stored);
  EXPECT_LT(fit["rmse"].get<double>(), 0.05) << fit;

  // The instrument's record: the model as the meter names itself, its serial number, and which
  // meter and grid it reported.
  const std::string where =
      " FROM instruments WHERE id = " + std::to_string(m["provenance"]["instrument_id"].get<long long>());
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT model" + where), meter.reported_model);
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT serial_number" + where), meter.serial);
  const json configuration = json::parse(sqlite_text(rig.db_path(), "SELECT spectral_configuration" + where));
  EXPECT_EQ(configuration["model"], meter.model) << configuration;
  EXPECT_EQ(configuration["reported_model"], meter.reported_model);
  EXPECT_EQ(configuration["family"], meter.family);
  EXPECT_EQ(configuration["firmware"], instrument["firmware"]);
  EXPECT_TRUE(configuration["bandwidth_nm"].is_number()) << configuration;
  const json grid = grid_of(meter);
  for (const auto& [key, value] : grid.items()) EXPECT_EQ(configuration[key], value) << key;

  // The export reads it back as the service shows it.
  const auto stopped = rig.stop_daemon();
  ASSERT_TRUE(stopped.exited()) << stopped.describe();
  const auto exported = run_process(kSkinspec, {"export", "--db", rig.db_path(), "--format", "json"});
  ASSERT_EQ(exported.exit_status, 0) << exported.describe();
  const json line = json::parse(exported.out.substr(0, exported.out.find('\n')));
  ASSERT_EQ(line["instruments"].size(), 1u) << line;
  EXPECT_EQ(line["instruments"][0]["model"], meter.reported_model);
  EXPECT_EQ(line["instruments"][0]["spectral_configuration"], configuration);
}

INSTANTIATE_TEST_SUITE_P(NewerMeters, Pr6xxSessionTest, ::testing::Values(kPr670, kPr730), model_name);

// A job's exposure is held to the identified meter's range when it is posted: 20 s is too long
// for a PR-650 (422, naming its range) and within a PR-730's, which takes it (and saturates).
TEST(Pr6xxExposureRange, AJobsExposureIsCheckedAgainstTheIdentifiedMeter) {
  for (const Meter& meter : {kPr650, kPr730}) {
    ScratchDirectory dir;
    AcquisitionRig rig(rig_for(dir, meter));
    ASSERT_TRUE(rig.ready()) << rig.logs();
    ASSERT_EQ(when_connected(rig.port)["state"], "connected") << meter << rig.logs();
    const long long session = new_session(rig.port, "E1");
    const json body = {{"kind", "white"}, {"integration_ms", 20000}};
    if (meter.model == "pr650") {
      const auto refused =
          http_request(rig.port, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements", body.dump());
      EXPECT_EQ(refused.status, 422) << refused.body;
      EXPECT_THAT(refused.body, ::testing::HasSubstr("out_of_range"));
      EXPECT_THAT(refused.body, ::testing::HasSubstr("10 to 6000 ms (the PR-650's range)"));
      EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT COUNT(*) FROM jobs"), "0");
    } else {
      // Taken by the meter: 20 s on a white standard under the simulated lamp saturates it.
      const auto job = wait_for_job(rig.port, submit(rig.port, session, body));
      EXPECT_EQ(job["request"]["integration_ms"], 20000) << job;
      ASSERT_EQ(job["state"], "failed") << job << rig.logs();
      EXPECT_EQ(job["error"]["code"], "bad_reading") << job;
      EXPECT_THAT(job["error"]["message"].get<std::string>(), ::testing::HasSubstr("overload")) << job;
    }
  }
}

// ---- The meter's settings from the API ------------------------------------------------------

// POST of a measurement that must be refused before a job exists: its reply.
HttpReply post_measurement(unsigned short port, long long session, const json& body) {
  return http_request(port, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements", body.dump());
}

// The exposure the simulator last chose: its log's last "measured '...': N ms exposure".
int last_exposure_logged(const std::string& log) {
  constexpr std::string_view kExposure = " ms exposure";
  const auto end = log.rfind(kExposure);
  if (end == std::string::npos) return -1;
  const auto start = log.rfind(' ', end - 1) + 1;
  return std::stoi(log.substr(start, end - start));
}

// The measurement `id` as the JSON export of its database shows it (skinspec export, beside the
// running daemon).
json exported_measurement(const AcquisitionRig& rig, long long id) {
  const auto exported = run_process(kSkinspec, {"export", "--db", rig.db_path(), "--format", "json"});
  if (exported.exit_status != 0) return {{"export", exported.describe()}};
  std::istringstream lines(exported.out);
  for (std::string line; std::getline(lines, line);) {
    const json session = json::parse(line);
    for (const json& m : session["measurements"])
      if (m["id"] == id) return m;
  }
  return nullptr;
}

// A PR-670's settings through the API: each is offered as the identified meter takes it (GET
// /api/v1/instrument's capabilities), reaches the meter, and is stored with the reading as
// provenance, shown by GET and by the export; an adaptive measurement keeps the exposure the
// meter chose (D13). A value the meter does not take is refused when posted: 422 naming what
// it takes, and no job.
TEST(Pr6xxJobSettings, EachSettingReachesTheMeterAndIsStoredWithTheReading) {
  ScratchDirectory dir;
  RigOptions options = rig_for(dir, kPr670);
  options.sim_args.push_back("--trace-bytes");
  AcquisitionRig rig(std::move(options));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const json instrument = when_connected(p);
  ASSERT_EQ(instrument["state"], "connected") << rig.logs();
  EXPECT_EQ(
      instrument["capabilities"],
      (json{{"model", "pr670"},
            {"integration_ms", {{"min", 6}, {"max", 6000}, {"max_extended", 30000}}},
            {"averages", {{"min", 1}, {"max", 99}}},
            {"sync", {{"modes", {"off", "auto", "frequency"}}, {"min_hz", 20}, {"max_hz", 400}, {"whole_hz", true}}},
            {"extended_sensitivity", true},
            {"apertures", {"1 deg", "1/2 deg", "1/4 deg", "1/8 deg"}}}))
      << instrument;

  const long long session = new_session(p, "S1");
  const json asked = {{"kind", "white"}, {"integration_ms", 100},        {"averages", 2},
                      {"sync", 60},      {"extended_sensitivity", true}, {"aperture", "1/2 DEG"}};
  const auto fixed = wait_for_job(p, submit(p, session, asked));
  ASSERT_EQ(fixed["state"], "succeeded") << fixed << rig.logs();
  for (const char* key : {"averages", "sync", "extended_sensitivity", "aperture"})
    EXPECT_EQ(fixed["request"][key], asked[key]) << key << ": " << fixed;
  const std::string log = rig.sim->err();
  for (const char* setup : {"SN02", "SS3", "SK060", "SH1", "SF1"})
    EXPECT_NE(log.find(std::string("received \"") + setup), std::string::npos) << setup << " never reached the meter";
  const long long fixed_id = id_of(fixed, "measurement_id");
  const json settings = get_json(p, "/api/v1/measurements/" + std::to_string(fixed_id))["provenance"]["settings"];
  EXPECT_EQ(settings["integration_ms"], 100) << settings;
  EXPECT_EQ(settings["averages"], 2) << settings;
  EXPECT_EQ(settings["sync"], "60 Hz (user)") << settings;
  EXPECT_EQ(settings["extended_sensitivity"], true) << settings;
  EXPECT_EQ(settings["aperture"], "1/2 DEG") << settings;
  EXPECT_EQ(settings["exposure_used_ms"], json::array({100})) << settings;

  // Adaptive: the exposure the meter chose, as D13 reports it.
  const auto adaptive = wait_for_job(p, submit(p, session, {{"kind", "sample"}}));
  ASSERT_EQ(adaptive["state"], "succeeded") << adaptive << rig.logs();
  const long long adaptive_id = id_of(adaptive, "measurement_id");
  const json chosen = get_json(p, "/api/v1/measurements/" + std::to_string(adaptive_id))["provenance"]["settings"];
  EXPECT_EQ(chosen["integration_ms"], 0) << chosen;
  const int logged = last_exposure_logged(rig.sim->err());
  ASSERT_GT(logged, 0) << rig.sim->err();
  EXPECT_EQ(chosen["exposure_used_ms"], json::array({logged})) << chosen;
  EXPECT_EQ(chosen["extended_sensitivity"], false) << chosen;
  EXPECT_EQ(chosen["aperture"], nullptr) << chosen;

  EXPECT_EQ(exported_measurement(rig, fixed_id)["provenance"]["settings"], settings);
  EXPECT_EQ(exported_measurement(rig, adaptive_id)["provenance"]["settings"], chosen);

  struct Refusal {
    json setting;
    std::string code, names;
  };
  for (const Refusal& r :
       {Refusal{{{"averages", 0}}, "out_of_range", "'averages' must be 1 to 99 (the PR-670's range)"},
        Refusal{{{"averages", 100}}, "out_of_range", "'averages' must be 1 to 99"},
        Refusal{{{"sync", 500}}, "out_of_range", "a frequency of 20 to 400 Hz in whole hertz (the PR-670's range)"},
        Refusal{{{"sync", 59.5}}, "out_of_range", "in whole hertz"},
        Refusal{{{"sync", "fast"}}, "invalid_value", "'sync' must be \"off\", \"auto\" or a frequency in Hz"},
        Refusal{{{"aperture", "2 deg"}}, "unknown_aperture", "one of '1 deg', '1/2 deg', '1/4 deg', '1/8 deg'"},
        Refusal{{{"integration_ms", 20000}}, "out_of_range", "6 to 6000 ms (the PR-670's range)"},
        Refusal{{{"integration_ms", 40000}, {"extended_sensitivity", true}},
                "out_of_range",
                "6 to 30000 ms (the PR-670's range with extended sensitivity)"}}) {
    json body = {{"kind", "sample"}};
    body.update(r.setting);
    const auto refused = post_measurement(p, session, body);
    EXPECT_EQ(refused.status, 422) << body << ": " << refused.body;
    const json error = refused.json()["error"];
    EXPECT_EQ(error["code"], r.code) << body << ": " << refused.body;
    EXPECT_THAT(error["message"].get<std::string>(), ::testing::HasSubstr(r.names)) << body;
  }
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT COUNT(*) FROM jobs"), "2") << "a refused job is never queued";
}

// A PR-650 has neither apertures nor extended sensitivity, and syncs to 40-250 Hz: asked for
// them, a job is refused when posted; its averages and sync are taken and stored. It does not
// report the exposure an adaptive measurement chose.
TEST(Pr6xxJobSettings, APr650RefusesWhatOnlyTheNewerMetersHave) {
  ScratchDirectory dir;
  AcquisitionRig rig(rig_for(dir, kPr650));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  const json instrument = when_connected(p);
  ASSERT_EQ(instrument["state"], "connected") << rig.logs();
  const json& caps = instrument["capabilities"];
  EXPECT_EQ(caps["model"], "pr650") << caps;
  EXPECT_EQ(caps["extended_sensitivity"], false) << caps;
  EXPECT_EQ(caps["apertures"], json::array()) << caps;
  EXPECT_EQ(caps["sync"]["min_hz"], 40) << caps;
  EXPECT_EQ(caps["sync"]["max_hz"], 250) << caps;
  EXPECT_EQ(caps["sync"]["whole_hz"], false) << caps;
  EXPECT_EQ(caps["integration_ms"]["max_extended"], nullptr) << caps;

  const long long session = new_session(p, "S2");
  for (const auto& [setting, message] :
       {std::pair{json{{"aperture", "1/2 deg"}}, "'aperture' must be left out: the PR-650 has no apertures to choose"},
        std::pair{json{{"extended_sensitivity", true}},
                  "'extended_sensitivity' must be false: the PR-650 has no extended sensitivity"},
        std::pair{json{{"sync", 300}}, "a frequency of 40 to 250 Hz (the PR-650's range)"},
        std::pair{json{{"averages", 100}}, "'averages' must be 1 to 99 (the PR-650's range)"}}) {
    json body = {{"kind", "white"}};
    body.update(setting);
    const auto refused = post_measurement(p, session, body);
    EXPECT_EQ(refused.status, 422) << body << ": " << refused.body;
    EXPECT_THAT(refused.body, ::testing::HasSubstr(message)) << body;
  }
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT COUNT(*) FROM jobs"), "0");

  const auto job = wait_for_job(p, submit(p, session, {{"kind", "white"}, {"averages", 3}, {"sync", 50.5}}));
  ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
  const json settings =
      get_json(p, "/api/v1/measurements/" + std::to_string(id_of(job, "measurement_id")))["provenance"]["settings"];
  EXPECT_EQ(settings["averages"], 3) << settings;
  EXPECT_EQ(settings["sync"], "50.5 Hz (user)") << settings;
  EXPECT_EQ(settings["exposure_used_ms"], json::array({nullptr})) << "the PR-650 does not say";
}

// A firmware that does not know D13 (illegal command): the adaptive measurement is stored, its
// exposure unknown (null), and the instrument says once what the meter lacks.
TEST(Pr6xxJobSettings, AMeterWithoutD13StoresTheExposureAsUnknown) {
  ScratchDirectory dir;
  RigOptions options = rig_for(dir, kPr730);
  options.sim_args.insert(options.sim_args.end(), {"--fault", "d13:error=-1000"});
  AcquisitionRig rig(std::move(options));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "S3");
  const auto job = wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}));
  ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
  const json m = get_json(rig.port, "/api/v1/measurements/" + std::to_string(id_of(job, "measurement_id")));
  EXPECT_EQ(m["provenance"]["settings"]["exposure_used_ms"], json::array({nullptr})) << m["provenance"];
  EXPECT_THAT(m["warnings"].dump(), ::testing::HasSubstr("no-exposure-report")) << m["warnings"];
  EXPECT_THAT(get_json(rig.port, "/api/v1/instrument")["warnings"].dump(), ::testing::HasSubstr("no-exposure-report"));
}

// Whether the simulator's log has the meter leaving remote mode after `after` (within `limit`).
bool quit_logged_after(BackgroundProcess& sim, std::string_view after, std::chrono::milliseconds limit) {
  for (auto until = std::chrono::steady_clock::now() + limit; std::chrono::steady_clock::now() < until;) {
    const std::string log = sim.err();
    const auto mark = log.find(after);
    if (mark != std::string::npos && log.find(kQuitLogged, mark) != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

// With the meter connected, idle and remote, skinspecd is ended by `signal` (`ended`: how); the
// meter must then leave remote mode.
void idle_daemon_ended_leaves_remote_mode(const ScratchDirectory& dir, const Meter& meter, int signal,
                                          ProcessResult& ended) {
  AcquisitionRig rig(rig_for(dir, meter));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  ASSERT_EQ(when_connected(rig.port)["state"], "connected") << rig.logs();
  ASSERT_TRUE(rig.sim->wait_for_stderr("command PHOTO: remote mode", 5s)) << rig.logs();
  EXPECT_EQ(rig.sim->err().find(kQuitLogged), std::string::npos) << "left remote mode before the test asked";
  ended = rig.stop_daemon(signal);
  EXPECT_TRUE(quit_logged_after(*rig.sim, "command PHOTO: remote mode", 10s)) << rig.logs();
}

// SIGTERM with the meter connected and idle: it is sent Q, leaving remote mode.
TEST_P(Pr6xxStopTest, SigtermLeavesRemoteModeWhenIdle) {
  ProcessResult stopped;
  idle_daemon_ended_leaves_remote_mode(dir_, GetParam(), SIGTERM, stopped);
  EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
}

// A crash (SIGABRT here, as abort() or an uncaught exception gives) cannot run the driver's
// disconnect: the fatal-signal handler writes Q to the meter's link on its way out.
TEST_P(Pr6xxStopTest, ACrashStillLeavesRemoteMode) {
  ProcessResult died;
  idle_daemon_ended_leaves_remote_mode(dir_, GetParam(), SIGABRT, died);
  EXPECT_EQ(died.signal, SIGABRT) << died.describe();
}

// SIGTERM while the meter measures: the measurement is cancelled (a PR-7xx's with A; a PR-670
// has no abort and finishes it), the job ends stopped, and Q still goes out.
TEST_P(Pr6xxStopTest, SigtermDuringAMeasurementCancelsItAndStillLeavesRemoteMode) {
  const Meter& meter = GetParam();
  // At time scale 0.2 a 6 s exposure keeps the simulated meter busy for about 2.5 s.
  AcquisitionRig rig(rig_for(dir_, meter, "0.2"));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "N2");
  const auto accepted = submit(rig.port, session, {{"kind", "white"}, {"integration_ms", 6000}});
  ASSERT_TRUE(accepted.contains("job_id")) << accepted;
  ASSERT_TRUE(rig.sim->wait_for_stderr("measured '", 30s)) << rig.logs();
  const auto stopped = rig.stop_daemon();
  EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
  EXPECT_TRUE(quit_logged_after(*rig.sim, "measured '", 20s)) << rig.logs();
  const std::string job = std::to_string(accepted["job_id"].get<long long>());
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT state FROM jobs WHERE id = " + job), "cancelled");
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT json_extract(error, '$.code') FROM jobs WHERE id = " + job), "stopped");
  EXPECT_EQ(sqlite_text(rig.db_path(), "SELECT COUNT(*) FROM measurements"), "0");
}

INSTANTIATE_TEST_SUITE_P(NewerMeters, Pr6xxStopTest, ::testing::Values(kPr670, kPr730), model_name);

std::vector<json> json_lines(const std::string& out) {
  std::vector<json> lines;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) lines.push_back(json::parse(line, nullptr, false));
  return lines;
}

// `skinspec measure --json` names the meter with each reading: model, the model it reports,
// serial number, firmware and grid, on which the reading lies.
TEST_P(MeasureCommandTest, JsonReadingsNameTheMeter) {
  const Meter& meter = GetParam();
  auto sim = start_simulator(dir_, "127.0.0.1:0", {"--model", meter.model, "--serial", meter.serial});
  ASSERT_NE(sim.port, 0) << sim.process->err();
  const auto result = run_process(kSkinspec, {"measure", "--device", "tcp:127.0.0.1:" + std::to_string(sim.port),
                                              "--model", model_flag(meter.model), "--count", "2", "--json"});
  ASSERT_EQ(result.exit_status, 0) << result.describe() << sim.process->err();
  const auto readings = json_lines(result.out);
  ASSERT_EQ(readings.size(), 2u) << result.out;
  for (const auto& reading : readings) {
    ASSERT_TRUE(reading.is_object()) << result.out;
    const json& instrument = reading["instrument"];
    EXPECT_EQ(instrument["model"], meter.model) << reading.dump().substr(0, 400);
    EXPECT_EQ(instrument["reported_model"], meter.reported_model);
    EXPECT_EQ(instrument["family"], meter.family);
    EXPECT_EQ(instrument["serial_number"], meter.serial);
    EXPECT_EQ(reading["serial"], meter.serial);
    // The PR-650 has no firmware report.
    EXPECT_EQ(instrument["firmware"].is_string(), meter.family != "pr650") << instrument;
    EXPECT_EQ(instrument["grid"], grid_of(meter));
    EXPECT_EQ(reading["radiance"].size(), static_cast<std::size_t>(meter.points));
    EXPECT_EQ(reading["wavelength_nm"].back(), meter.last_nm);
  }
  // A newer meter is let go of with Q when the command ends.
  if (meter.family != "pr650") {
    EXPECT_TRUE(sim.process->wait_for_stderr(kQuitLogged, 5s)) << sim.process->err();
  }
}

// SIGTERM while `skinspec measure` waits for a PR-670's measurement: it stops with status 3, and
// the meter is let go of with Q, which it acts on once the measurement is over.
// The newer meters' settings from the command line: a sync frequency (SS3, SK), averaging, the
// extended exposure range (SH1) and an aperture by the name the meter lists (SF); a model
// without them refuses before measuring, and a malformed value is bad input.
TEST(MeasureCommandSettings, ANewerMetersSettingsReachItAndAPr650RefusesThem) {
  ScratchDirectory dir;
  auto pr670 = start_simulator(dir, "127.0.0.1:0", {"--model", "pr670", "--serial", kPr670.serial});
  ASSERT_NE(pr670.port, 0) << pr670.process->err();
  const std::string device = "tcp:127.0.0.1:" + std::to_string(pr670.port);
  const auto result =
      run_process(kSkinspec, {"measure", "--device", device, "--sync", "60", "--averages", "2",
                              "--extended-sensitivity", "--integration-ms", "100", "--aperture", "1/2 deg", "--json"});
  ASSERT_EQ(result.exit_status, 0) << result.describe() << pr670.process->err();
  const auto readings = json_lines(result.out);
  ASSERT_EQ(readings.size(), 1u) << result.out;
  EXPECT_EQ(readings[0]["integration_ms"], 100) << result.out;
  EXPECT_EQ(readings[0]["averages"], 2) << result.out;
  EXPECT_THAT(readings[0]["sync"].get<std::string>(), ::testing::HasSubstr("60")) << result.out;

  // 20 s is beyond a PR-670's normal range and within its extended one, where the meter takes
  // it (and saturates on the simulator's bright default source).
  const std::vector<std::string> long_exposure = {"measure", "--device",         device, "--model",
                                                  "pr670",   "--integration-ms", "20000"};
  const auto too_long = run_process(kSkinspec, long_exposure);
  EXPECT_EQ(too_long.exit_status, 2) << too_long.describe();
  EXPECT_THAT(too_long.err, ::testing::HasSubstr("expected 6-6000 (the PR-670's range)")) << too_long.describe();
  auto extended = long_exposure;
  extended.push_back("--extended-sensitivity");
  const auto taken = run_process(kSkinspec, extended);
  EXPECT_EQ(taken.exit_status, 3) << taken.describe();
  EXPECT_THAT(taken.err, ::testing::HasSubstr("overload")) << taken.describe();

  auto pr650 = start_simulator(dir, "127.0.0.1:0", {"--model", "pr650"});
  ASSERT_NE(pr650.port, 0) << pr650.process->err();
  const auto refused = run_process(
      kSkinspec, {"measure", "--device", "tcp:127.0.0.1:" + std::to_string(pr650.port), "--aperture", "1/2 deg"});
  EXPECT_EQ(refused.exit_status, 3) << refused.describe();
  EXPECT_THAT(refused.err, ::testing::HasSubstr("no apertures")) << refused.describe();

  const auto malformed = run_process(kSkinspec, {"measure", "--device", device, "--sync", "fast"});
  EXPECT_EQ(malformed.exit_status, 2) << malformed.describe();
  EXPECT_THAT(malformed.err, ::testing::HasSubstr("--sync 'fast'")) << malformed.describe();
}

TEST(MeasureCommandSignals, SigtermDuringAMeasurementStillLeavesRemoteMode) {
  ScratchDirectory dir;
  auto sim = start_simulator(dir, "127.0.0.1:0", {"--model", kPr670.model}, "0.2");
  ASSERT_NE(sim.port, 0) << sim.process->err();
  BackgroundProcess measure(kSkinspec, {"measure", "--device", "tcp:127.0.0.1:" + std::to_string(sim.port), "--model",
                                        model_flag(kPr670.model), "--integration-ms", "6000"});
  ASSERT_TRUE(sim.process->wait_for_stderr("measured '", 30s)) << sim.process->err();
  measure.send_signal(SIGTERM);
  const auto ended = measure.wait(20s);
  EXPECT_EQ(ended.exit_status, 3) << ended.describe();
  EXPECT_NE(ended.err.find("stopped by SIGTERM"), std::string::npos) << ended.err;
  EXPECT_TRUE(quit_logged_after(*sim.process, "measured '", 20s)) << sim.process->err();
}

INSTANTIATE_TEST_SUITE_P(EachFamily, MeasureCommandTest, ::testing::Values(kPr650, kPr670, kPr730), model_name);

// ---- Firmware generations with real processes ---------------------------------------------

// A PR-730 whose firmware lacks T measures every job with M5, and the instrument says so once.
TEST(Pr7xxFirmwareProcess, APr730WithoutTMeasuresWithM5AndTheInstrumentWarnsOnce) {
  ScratchDirectory dir;
  RigOptions options = rig_for(dir, kPr730);
  options.sim_args.insert(options.sim_args.end(), {"--firmware", "m730"});
  AcquisitionRig rig(options);
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "F1");
  for (int i = 0; i < 2; ++i) {
    const auto job = wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}}));
    ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
  }
  const json instrument = get_json(rig.port, "/api/v1/instrument");
  const auto m5 = std::ranges::count_if(instrument["warnings"],
                                        [](const json& w) { return w.get<std::string>().starts_with("m5-fallback"); });
  EXPECT_EQ(m5, 1) << instrument;
  EXPECT_TRUE(rig.sim->wait_for_stderr("unknown command 'T'", 1s)) << rig.logs();
  const std::string log = rig.sim->err();
  EXPECT_EQ(log.find("unknown command 'T'"), log.rfind("unknown command 'T'")) << "T is tried once";
}

// ---- No hang, and the time left ------------------------------------------------------------

// Two 120 s readings on a PR-730 (at a hundredth of the time): the job succeeds, and while it
// measures its progress says how long it may still take, never more than a moment before.
TEST(Pr7xxDeadlinesProcess, ALongExposureFinishesAndShowsTheTimeLeftThroughout) {
  ScratchDirectory dir;
  // A dim lamp, so that 120 s fills the detector about halfway.
  AcquisitionRig rig(rig_options(dir.path().string(),
                                 {"--model", "pr730", "--time-scale", "0.01", "--white-luminance", "0.4"},
                                 {"--model", "pr730"}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const long long session = new_session(rig.port, "L1");
  const auto accepted = submit(rig.port, session, {{"kind", "white"}, {"integration_ms", 120000}, {"count", 2}});
  ASSERT_TRUE(accepted.contains("job_id")) << accepted;
  const std::string target = "/api/v1/jobs/" + std::to_string(accepted["job_id"].get<long long>());
  std::optional<double> last;
  int measuring_looks = 0;
  json job;
  for (auto until = std::chrono::steady_clock::now() + 40s; std::chrono::steady_clock::now() < until;) {
    job = get_json(rig.port, target);
    const std::string state = job.value("state", "");
    if (state != "queued" && state != "running") break;
    const json& progress = job["progress"];
    if (progress.value("phase", "") == "measuring") {
      ASSERT_TRUE(progress.contains("remaining_s") && progress["remaining_s"].is_number()) << job;
      const double left = progress["remaining_s"].get<double>();
      EXPECT_GT(left, 0) << job;
      if (last) {
        EXPECT_LE(left, *last + 0.5) << "the time left only goes down: " << job;
      }
      last = left;
      ++measuring_looks;
    }
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(job["state"], "succeeded") << job << rig.logs();
  EXPECT_GT(measuring_looks, 10) << "followed while it measured";
  EXPECT_GE(last.value_or(0), 0);
}

// ---- Q alone: a stop at every byte of a paced command -------------------------------------

// What skinspec-sim logs as each byte of `command`'s first `bytes` bytes arrives.
std::string traced(std::string_view command, std::size_t bytes) {
  std::string shown;
  for (const char c : command.substr(0, bytes)) shown += c == '\r' ? std::string("\\r") : std::string(1, c);
  return "received \"" + shown + "\"";
}

// Waits until the simulator's log, after `mark` and after the whole of `before` when given (the
// command sent just before, so that an "S" is the first byte of this setup and not of another),
// shows the first `bytes` bytes of `command`.
bool wait_for_bytes(BackgroundProcess& sim, std::size_t mark, std::string_view command, std::size_t bytes,
                    std::chrono::milliseconds limit = 20s, std::string_view before = {}) {
  const std::string line = traced(command, bytes);
  const std::string previous = before.empty() ? std::string() : traced(before, before.size());
  for (auto until = std::chrono::steady_clock::now() + limit; std::chrono::steady_clock::now() < until;) {
    const std::string log = sim.err();
    const auto from = previous.empty() ? mark : log.find(previous, mark);
    if (from != std::string::npos && log.find(line, from) != std::string::npos) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

// After `mark`, the meter took no command it did not know (a "D11Q"), refused none, and left
// remote mode on a Q of its own.
void expect_q_alone(BackgroundProcess& sim, std::size_t mark, const std::string& where) {
  for (auto until = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < until;) {
    if (sim.err().find(kQuitLogged, mark) != std::string::npos) break;
    std::this_thread::sleep_for(10ms);
  }
  const std::string log = sim.err().substr(mark);
  EXPECT_NE(log.find(kQuitLogged), std::string::npos) << where << "\n" << log;
  EXPECT_EQ(log.find("unknown command"), std::string::npos) << where << "\n" << log;
  EXPECT_EQ(log.find("refused"), std::string::npos) << where << "\n" << log;
  EXPECT_NE(log.find("received \"Q\""), std::string::npos) << where;
}

RigOptions traced_rig(const ScratchDirectory& dir, const Meter& meter) {
  return rig_options(dir.path().string(),
                     {"--model", meter.model, "--serial", meter.serial, "--time-scale", "0", "--trace-bytes"},
                     {"--model", meter.model, "--instrument-check-ms", "100"});
}

// SIGTERM while skinspecd's idle check sends D110, after each of its bytes in turn.
TEST(Pr6xxQuitAloneProcess, SigtermAtEveryByteOfTheIdleCheck) {
  ScratchDirectory dir;
  AcquisitionRig rig(traced_rig(dir, kPr670));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const std::string d110 = "D110\r";
  for (std::size_t bytes = 1; bytes <= d110.size(); ++bytes) {
    const std::string where = "SIGTERM after " + std::to_string(bytes) + " bytes of D110";
    if (bytes > 1) rig.restart_daemon();
    ASSERT_EQ(when_connected(rig.port)["state"], "connected") << rig.logs();
    const std::size_t mark = rig.sim->err().size();
    ASSERT_TRUE(wait_for_bytes(*rig.sim, mark, d110, bytes)) << where << rig.logs();
    const auto stopped = rig.stop_daemon();
    EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
    expect_q_alone(*rig.sim, mark, where);
  }
}

// SIGTERM while a job sends its exposure (SE00123), after each of its bytes in turn.
void sigterm_at_bytes_of_a_setup(std::size_t from, std::size_t to) {
  ScratchDirectory dir;
  AcquisitionRig rig(traced_rig(dir, kPr670));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const std::string setup = "SE00123\r";
  for (std::size_t bytes = from; bytes <= to; ++bytes) {
    const std::string where = "SIGTERM after " + std::to_string(bytes) + " bytes of SE00123";
    if (bytes > from) rig.restart_daemon();
    ASSERT_EQ(when_connected(rig.port)["state"], "connected") << rig.logs();
    const std::size_t mark = rig.sim->err().size();
    const long long session = new_session(rig.port, "Q" + std::to_string(bytes));
    const auto accepted = submit(rig.port, session, {{"kind", "white"}, {"integration_ms", 123}});
    ASSERT_TRUE(accepted.contains("job_id")) << accepted;
    ASSERT_TRUE(wait_for_bytes(*rig.sim, mark, setup, bytes, 20s, "SH0\r")) << where << rig.logs();
    const auto stopped = rig.stop_daemon();
    EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
    expect_q_alone(*rig.sim, mark, where);
  }
}

TEST(Pr6xxQuitAloneProcess, SigtermAtTheFirstBytesOfASetup) { sigterm_at_bytes_of_a_setup(1, 4); }
TEST(Pr6xxQuitAloneProcess, SigtermAtTheLastBytesOfASetup) { sigterm_at_bytes_of_a_setup(5, 8); }

// A job cancelled while it sends its exposure, after each byte in turn, on one connection: the
// setup still reaches the meter whole, so the next job's commands and the final Q are its own.
TEST(Pr6xxQuitAloneProcess, CancelAtEveryByteOfASetup) {
  ScratchDirectory dir;
  AcquisitionRig rig(traced_rig(dir, kPr670));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  ASSERT_EQ(when_connected(rig.port)["state"], "connected") << rig.logs();
  const std::size_t start = rig.sim->err().size();
  const long long session = new_session(rig.port, "C1");
  // The other setups once, so that each job after sends its exposure first.
  const auto first = wait_for_job(rig.port, submit(rig.port, session, {{"kind", "white"}, {"integration_ms", 100}}));
  ASSERT_EQ(first["state"], "succeeded") << first << rig.logs();
  for (std::size_t bytes = 1; bytes <= 8; ++bytes) {
    const int exposure = 100 + static_cast<int>(bytes);  // a new SE every job
    const std::string setup = "SE00" + std::to_string(exposure) + "\r";
    const std::string where = "cancel after " + std::to_string(bytes) + " bytes of " + setup.substr(0, 7);
    const std::size_t mark = rig.sim->err().size();
    const auto accepted = submit(rig.port, session, {{"kind", "white"}, {"integration_ms", exposure}});
    ASSERT_TRUE(accepted.contains("job_id")) << accepted;
    ASSERT_TRUE(wait_for_bytes(*rig.sim, mark, setup, bytes)) << where << rig.logs();
    const std::string target = "/api/v1/jobs/" + std::to_string(accepted["job_id"].get<long long>());
    const auto cancelled = http_request(rig.port, "DELETE", target, "");
    EXPECT_EQ(cancelled.status, 200) << where << cancelled.body;
    const auto job = wait_for_job(rig.port, accepted);
    EXPECT_TRUE(job["state"] == "cancelled" || job["state"] == "succeeded") << where << job;
    EXPECT_TRUE(wait_for_bytes(*rig.sim, mark, setup, setup.size(), 5s)) << where << ": sent whole";
  }
  const auto stopped = rig.stop_daemon();
  EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
  expect_q_alone(*rig.sim, start, "cancel at every byte");
}
}  // namespace
}  // namespace skinspec::testing
