// The instrument connection with real processes on loopback: skinspecd keeps a skinspec-sim
// meter connected in the background, notices it going away, reconnects with backoff, and
// stays responsive and stoppable while the meter is gone.

#include <gtest/gtest.h>

#include <csignal>
#include <functional>
#include <thread>

#include "skinspec/client/http_client.hpp"
#include "support/job_error.hpp"
#include "support/service_processes.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

// Quick retries and checks, so that losses and returns show within a fraction of a second.
const std::vector<std::string> kFastReconnect = {"--reconnect-initial-ms", "50", "--reconnect-max-ms", "200",
                                                 "--instrument-check-ms",  "100"};

json instrument(unsigned short port) { return http_request(port, "GET", "/api/v1/instrument").json(); }

// Polls the instrument's status until `done` says so (or 30 s passed); the last status.
json wait_for_instrument(unsigned short port, const std::function<bool(const json&)>& done) {
  json status;
  for (int i = 0; i < 1500; ++i) {
    status = instrument(port);
    if (done(status)) return status;
    std::this_thread::sleep_for(20ms);
  }
  return status;
}

json wait_for_state(unsigned short port, const std::string& state) {
  return wait_for_instrument(port, [&](const json& s) { return s.value("state", "") == state; });
}

bool has_failed_attempts(const json& s) { return s.value("attempts", 0) >= 1; }

long long open_session(unsigned short port) {
  const auto r = http_request(port, "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "V1"}}.dump());
  EXPECT_EQ(r.status, 201) << r.body;
  return r.json().value("id", 0LL);
}

// Submits a white measurement and waits for its job to end; the job.
json measure_white(unsigned short port, long long session) {
  const auto r = http_request(port, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements",
                              R"({"kind":"white"})");
  EXPECT_EQ(r.status, 202) << r.body;
  const std::string path = "/api/v1/jobs/" + std::to_string(r.json().value("job_id", 0LL));
  json job;
  for (int i = 0; i < 1500; ++i) {
    job = http_request(port, "GET", path).json();
    if (job.value("state", "") != "queued" && job.value("state", "") != "running") return job;
    std::this_thread::sleep_for(20ms);
  }
  return job;
}

// A loopback port nobody listens on any more: the one a simulator had until it was stopped.
unsigned short vacated_port(const ScratchDirectory& dir) {
  auto sim = start_simulator(dir, "127.0.0.1:0");
  sim.process->send_signal(SIGTERM);
  (void)sim.process->wait(20s);
  return sim.port;
}

std::string loopback(unsigned short port) { return "127.0.0.1:" + std::to_string(port); }

// skinspecd with the meter at this loopback port, retrying and checking quickly.
ListeningProcess start_daemon_for_meter(const ScratchDirectory& dir, unsigned short meter_port) {
  std::vector<std::string> args = {"--device", "tcp:" + loopback(meter_port)};
  args.insert(args.end(), kFastReconnect.begin(), kFastReconnect.end());
  return start_daemon(dir, args);
}

void kill_meter(ListeningProcess& sim) {
  sim.process->send_signal(SIGKILL);
  (void)sim.process->wait(20s);
}

class ReconnectTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
};

TEST_F(ReconnectTest, AKilledSimulatorIsReconnectedInTheBackgroundWhenItComesBack) {
  auto sim = start_simulator(dir_, "127.0.0.1:0");
  ASSERT_NE(sim.port, 0) << sim.process->err();
  auto daemon = start_daemon_for_meter(dir_, sim.port);
  ASSERT_NE(daemon.port, 0) << daemon.process->err();

  // Connected at start, before any job.
  auto status = wait_for_state(daemon.port, "connected");
  ASSERT_EQ(status["state"], "connected") << status << daemon.process->err();
  EXPECT_EQ(status["port"], "tcp:" + loopback(sim.port));
  EXPECT_TRUE(status["serial_number"].is_string()) << status;
  EXPECT_TRUE(status["since"].is_string()) << status;

  // The idle check notices the meter is gone; no job was submitted.
  kill_meter(sim);
  status =
      wait_for_instrument(daemon.port, [](const json& s) { return s["state"] == "lost" && has_failed_attempts(s); });
  ASSERT_EQ(status["state"], "lost") << status;
  EXPECT_TRUE(status["last_error"].is_string()) << status;
  EXPECT_TRUE(status["next_attempt_in_ms"].is_number_integer()) << status;

  sim = start_simulator(dir_, loopback(sim.port));
  ASSERT_NE(sim.port, 0) << sim.process->err();
  status = wait_for_state(daemon.port, "connected");
  ASSERT_EQ(status["state"], "connected") << status << daemon.process->err();
  EXPECT_EQ(status["attempts"], 0);
  EXPECT_TRUE(status["next_attempt_in_ms"].is_null()) << status;

  const long long session = open_session(daemon.port);
  const auto job = measure_white(daemon.port, session);
  EXPECT_EQ(job["state"], "succeeded") << job << daemon.process->err();
}

TEST_F(ReconnectTest, AMeasurementWhileTheMeterIsDownFailsClearlyAndTheServiceKeepsServing) {
  auto sim = start_simulator(dir_, "127.0.0.1:0");
  ASSERT_NE(sim.port, 0) << sim.process->err();
  auto daemon = start_daemon_for_meter(dir_, sim.port);
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const long long session = open_session(daemon.port);
  ASSERT_EQ(measure_white(daemon.port, session)["state"], "succeeded") << daemon.process->err();

  // The job finds the link closed, connects again once, at once (not after the backoff), and
  // fails with the reason.
  kill_meter(sim);
  const auto failed = measure_white(daemon.port, session);
  EXPECT_EQ(failed["state"], "failed") << failed;
  EXPECT_EQ(failed["error"]["code"], "transport") << failed;
  EXPECT_TRUE(failed["error"]["message"].get<std::string>().starts_with("cannot open tcp:" + loopback(sim.port)))
      << failed;

  const auto health = http_request(daemon.port, "GET", "/healthz");
  EXPECT_EQ(health.status, 200) << health.body;
  EXPECT_EQ(health.json()["instrument"]["state"], "lost") << health.body;

  sim = start_simulator(dir_, loopback(sim.port));
  ASSERT_NE(sim.port, 0) << sim.process->err();
  ASSERT_EQ(wait_for_state(daemon.port, "connected")["state"], "connected") << daemon.process->err();
  const auto again = measure_white(daemon.port, session);
  EXPECT_EQ(again["state"], "succeeded") << again << daemon.process->err();
}

TEST_F(ReconnectTest, AMeterKilledWhileIdleShowsLostAtOnceAndAJobRightAfterItsRestartSucceeds) {
  auto sim = start_simulator(dir_, "127.0.0.1:0");
  ASSERT_NE(sim.port, 0) << sim.process->err();
  // No idle check for ten minutes: only the link's hang-up can tell the daemon the meter went.
  auto daemon = start_daemon(dir_, {"--device", "tcp:" + loopback(sim.port), "--instrument-check-ms", "600000"});
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const long long session = open_session(daemon.port);
  ASSERT_EQ(wait_for_state(daemon.port, "connected")["state"], "connected") << daemon.process->err();

  kill_meter(sim);
  auto status = wait_for_state(daemon.port, "lost");
  ASSERT_EQ(status["state"], "lost") << status << daemon.process->err();
  EXPECT_NE(daemon.process->err().find("was closed"), std::string::npos) << daemon.process->err();

  // The daemon's own attempts now wait out their backoff; the job connects at once.
  sim = start_simulator(dir_, loopback(sim.port));
  ASSERT_NE(sim.port, 0) << sim.process->err();
  const auto job = measure_white(daemon.port, session);
  EXPECT_EQ(job["state"], "succeeded") << job << daemon.process->err();
}

// A simulator with `faults` and a daemon for it; a session whose first white succeeds, then the
// second white job, which the faults aim at.
struct SecondWhite {
  ListeningProcess sim, daemon;
  json job;
};

SecondWhite second_white_job(const ScratchDirectory& dir, const std::vector<std::string>& faults) {
  SecondWhite out;
  out.sim = start_simulator(dir, "127.0.0.1:0", faults);
  EXPECT_NE(out.sim.port, 0) << out.sim.process->err();
  out.daemon = start_daemon_for_meter(dir, out.sim.port);
  EXPECT_NE(out.daemon.port, 0) << out.daemon.process->err();
  const long long session = open_session(out.daemon.port);
  EXPECT_EQ(measure_white(out.daemon.port, session)["state"], "succeeded") << out.daemon.process->err();
  out.job = measure_white(out.daemon.port, session);
  return out;
}

TEST_F(ReconnectTest, AJobWhoseFirstCommandFindsTheMeterSilentConnectsAgainOnceAndMeasures) {
  // The second job's setup goes unanswered twice, as from a meter switched off and on behind a
  // link that stayed up: the job connects again (first contact, identification) and measures.
  const auto run = second_white_job(dir_, {"--fault", "s:no-answer@2", "--fault", "s:no-answer@3"});
  EXPECT_EQ(run.job["state"], "succeeded") << run.job << run.daemon.process->err();
  EXPECT_NE(run.daemon.process->err().find("event=instrument_reconnect_for_job"), std::string::npos)
      << run.daemon.process->err();
  EXPECT_EQ(instrument(run.daemon.port)["state"], "connected");
}

TEST_F(ReconnectTest, AJobWhileTheMeterStaysSilentFailsClearlyAfterConnectingAgainOnce) {
  // The second job's setup reboots the meter: silent until power-cycled, which nobody does.
  const auto run = second_white_job(dir_, {"--fault", "s:reboot@2"});
  ASSERT_EQ(run.job["state"], "failed") << run.job;
  ASSERT_TRUE(run.job["error"].is_object()) << run.job;
  const std::string error = job_error_text(run.job);
  EXPECT_TRUE(error.starts_with("no_contact: ")) << error;
  EXPECT_NE(error.find("did not answer 's01"), std::string::npos) << error;
  EXPECT_NE(error.find("connecting again failed: no answer from a PR-650"), std::string::npos) << error;
  EXPECT_NE(error.find("switch it off, switch it on"), std::string::npos) << error;
  EXPECT_EQ(http_request(run.daemon.port, "GET", "/healthz").status, 200);
}

TEST_F(ReconnectTest, ADaemonStartedBeforeTheSimulatorConnectsWhenItAppears) {
  const unsigned short meter_port = vacated_port(dir_);
  ASSERT_NE(meter_port, 0);
  auto daemon = start_daemon_for_meter(dir_, meter_port);
  ASSERT_NE(daemon.port, 0) << daemon.process->err();

  auto status = wait_for_instrument(daemon.port, has_failed_attempts);
  EXPECT_EQ(status["state"], "disconnected") << status;  // never reached yet, so not "lost"
  EXPECT_TRUE(status["last_error"].is_string()) << status;

  auto sim = start_simulator(dir_, loopback(meter_port));
  ASSERT_NE(sim.port, 0) << sim.process->err();
  status = wait_for_state(daemon.port, "connected");
  EXPECT_EQ(status["state"], "connected") << status << daemon.process->err();
}

TEST_F(ReconnectTest, SigtermWhileWaitingToReconnectEndsTheDaemonAtOnce) {
  const unsigned short meter_port = vacated_port(dir_);
  ASSERT_NE(meter_port, 0);
  // After the first failure the next attempt is ten minutes away: only a wait that SIGTERM
  // interrupts lets the daemon end within the 20 s below.
  auto daemon = start_daemon(dir_, {"--device", "tcp:" + loopback(meter_port), "--reconnect-initial-ms", "600000",
                                    "--reconnect-max-ms", "600000"});
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const auto status = wait_for_instrument(daemon.port, has_failed_attempts);
  ASSERT_TRUE(has_failed_attempts(status)) << status;
  EXPECT_GT(status["next_attempt_in_ms"].get<long long>(), 60000) << status;

  daemon.process->send_signal(SIGTERM);
  const auto ended = daemon.process->wait(20s);
  EXPECT_FALSE(ended.timed_out) << ended.describe();
  EXPECT_EQ(ended.exit_status, 0) << ended.describe();
}

TEST_F(ReconnectTest, PortsListsDiscoveryResultsAsJson) {
  auto daemon = start_daemon(dir_, {"--device", "auto"});
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const auto r = http_request(daemon.port, "GET", "/api/v1/ports");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto body = r.json();
  ASSERT_TRUE(body["ports"].is_array()) << r.body;  // may be empty on a machine without ports
  for (const auto& port : body["ports"]) {
    EXPECT_TRUE(port["uri"].is_string() && port["name"].is_string() && port["transport"].is_string()) << port;
    EXPECT_TRUE(port["usb"].is_null() || port["usb"]["vid"].is_string()) << port;
  }
  EXPECT_EQ(http_request(daemon.port, "GET", "/api/v1/ports?x=1").status, 400);

  const auto openapi = http_request(daemon.port, "GET", "/openapi.json").json();
  EXPECT_TRUE(openapi["paths"].contains("/api/v1/ports"));
  EXPECT_TRUE(openapi["components"]["schemas"]["Instrument"]["properties"].contains("next_attempt_in_ms"));
}

TEST_F(ReconnectTest, PortsWithoutAnInstrumentIsUnavailable) {
  auto daemon = start_daemon(dir_, {});
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const auto r = http_request(daemon.port, "GET", "/api/v1/ports");
  EXPECT_EQ(r.status, 503) << r.body;
  EXPECT_EQ(r.json()["error"]["code"], "no_instrument") << r.body;
}

TEST_F(ReconnectTest, AutoWithoutAnAdapterSaysSoAndJobsFailCleanly) {
  auto daemon = start_daemon(dir_, {"--device", "auto", "--reconnect-initial-ms", "100", "--reconnect-max-ms", "200"});
  ASSERT_NE(daemon.port, 0) << daemon.process->err();
  const auto listing = http_request(daemon.port, "GET", "/api/v1/ports").json();
  for (const auto& port : listing["ports"])
    if (!port["usb"].is_null()) GTEST_SKIP() << "this machine has a USB serial adapter: " << port;

  const auto status = wait_for_instrument(daemon.port, has_failed_attempts);
  EXPECT_EQ(status["state"], "disconnected") << status;
  EXPECT_NE(status.value("last_error", "").find("no USB serial adapter found"), std::string::npos) << status;
  EXPECT_TRUE(status["port"].is_null()) << status;

  const auto job = measure_white(daemon.port, open_session(daemon.port));
  EXPECT_EQ(job["state"], "failed") << job;
  EXPECT_EQ(job["error"]["code"], "transport") << job;
  EXPECT_NE(job["error"]["message"].get<std::string>().find("no USB serial adapter found"), std::string::npos) << job;
  EXPECT_EQ(http_request(daemon.port, "GET", "/healthz").status, 200);
  EXPECT_FALSE(daemon.process->has_exited());
}

}  // namespace
}  // namespace skinspec::testing
