// A real skinspecd on loopback, driven over HTTP: every route, bad input on the wire, limits,
// slow clients, tokens off loopback, graceful stop and a restart that keeps all data.

#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sys/stat.h>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>

#include "skinspec/client/http_client.hpp"
#include "support/raw_exchange.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/version.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

const std::string kDaemon = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd";

// skinspecd on a free loopback port, over a database in a scratch directory.
class Daemon {
 public:
  Daemon(const std::string& db, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--db", db, "--log-level", "debug"};
    args.insert(args.end(), extra.begin(), extra.end());
    process_ = std::make_unique<BackgroundProcess>(kDaemon, args);
    const auto line = process_->wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
    if (line) port_ = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
  }
  unsigned short port() const { return port_; }
  BackgroundProcess& process() { return *process_; }
  ProcessResult stop() {
    process_->send_signal(SIGTERM);
    return process_->wait(30s);
  }

 private:
  std::unique_ptr<BackgroundProcess> process_;
  unsigned short port_ = 0;
};

std::vector<double> grid() {
  std::vector<double> wl;
  for (int w = 380; w <= 780; w += 4) wl.push_back(w);
  return wl;
}
std::vector<double> skin_like() {
  std::vector<double> r;
  for (double w : grid()) r.push_back(0.25 + 0.0006 * (w - 380));
  return r;
}

void expect_error(const HttpReply& r, int status, const std::string& code) {
  EXPECT_EQ(r.status, status) << r.body << r.error;
  const json b = r.json();
  ASSERT_TRUE(b.is_object() && b.contains("error")) << r.body;
  EXPECT_EQ(b["error"]["code"], code) << r.body;
}

class DaemonTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
};

TEST_F(DaemonTest, EveryRouteOverHttpAndARestartKeepsTheData) {
  store::Id session = 0, ws = 0;
  std::string csv;
  {
    Daemon d(dir_.file("lab.db"));
    ASSERT_NE(d.port(), 0) << d.process().err();
    const auto p = d.port();
    EXPECT_EQ(http_request(p, "GET", "/healthz").json()["database"]["state"], "open");
    EXPECT_EQ(http_request(p, "GET", "/openapi.json").json()["openapi"], "3.1.0");
    const auto fitted =
        http_request(p, "POST", "/api/v1/fit", json{{"wavelength_nm", grid()}, {"reflectance", skin_like()}}.dump());
    ASSERT_EQ(fitted.status, 200) << fitted.body;
    EXPECT_TRUE(fitted.json()["converged"].is_boolean());
    const auto several = http_request(p, "POST", "/api/v1/fit",
                                      json{{"wavelength_nm", grid()}, {"spectra", {{"a", skin_like()}}}}.dump());
    EXPECT_EQ(several.json()["fits"][0]["params"], fitted.json()["params"]);

    const auto w =
        http_request(p, "POST", "/api/v1/white-standards",
                     json{{"name", "PTFE"}, {"wavelength_nm", {380, 780}}, {"reflectance", {0.99, 0.98}}}.dump());
    ASSERT_EQ(w.status, 201) << w.body;
    ws = w.json()["id"];
    EXPECT_EQ(w.header("location"), "/api/v1/white-standards/" + std::to_string(ws));
    EXPECT_EQ(http_request(p, "GET", "/api/v1/white-standards").json()["white_standards"].size(), 1u);
    EXPECT_EQ(http_request(p, "GET", "/api/v1/white-standards/" + std::to_string(ws)).status, 200);

    const auto s =
        http_request(p, "POST", "/api/v1/sessions",
                     json{{"site", "forearm"}, {"subject", "V1"}, {"white_standard_id", ws}, {"notes", "n"}}.dump());
    ASSERT_EQ(s.status, 201) << s.body;
    session = s.json()["id"];
    EXPECT_EQ(http_request(p, "GET", "/api/v1/sessions?site=forearm&limit=10").json()["sessions"].size(), 1u);
    const auto m = http_request(p, "GET", "/api/v1/measurements/1");
    expect_error(m, 404, "not_found");
    const auto patched =
        http_request(p, "PATCH", "/api/v1/sessions/" + std::to_string(session), json{{"notes", "windy"}}.dump());
    ASSERT_EQ(patched.status, 200) << patched.body;
    const auto detail = http_request(p, "GET", "/api/v1/sessions/" + std::to_string(session));
    EXPECT_EQ(detail.json()["notes"], "windy");
    csv = http_request(p, "GET", "/api/v1/sessions/" + std::to_string(session) + "/export.csv").body;
    EXPECT_EQ(csv.find("\nsession_id,"), csv.find('\n'));  // below the units' comment line
    const auto metrics = http_request(p, "GET", "/metrics");
    EXPECT_NE(metrics.body.find("skinspec_fits_total{outcome=\"ok\"} 2"), std::string::npos) << metrics.body;
    const auto ended = d.stop();
    EXPECT_TRUE(ended.exited() && ended.exit_status == 0) << ended.describe();
    EXPECT_NE(ended.err.find("event=stopped"), std::string::npos);
  }
  Daemon again(dir_.file("lab.db"));
  ASSERT_NE(again.port(), 0) << again.process().err();
  const auto detail = http_request(again.port(), "GET", "/api/v1/sessions/" + std::to_string(session));
  ASSERT_EQ(detail.status, 200);
  EXPECT_EQ(detail.json()["notes"], "windy");
  EXPECT_EQ(detail.json()["white_standard_id"], ws);
  EXPECT_EQ(http_request(again.port(), "GET", "/api/v1/white-standards/" + std::to_string(ws)).json()["reflectance"][1],
            0.98);
  EXPECT_EQ(http_request(again.port(), "GET", "/api/v1/sessions/" + std::to_string(session) + "/export.csv").body, csv);
}

TEST_F(DaemonTest, MeasurementsAndRefitsOfAStoredSession) {
  // A database with a measurement in it, as acquisition would leave it.
  store::Id m = 0;
  {
    auto db = store::Store::open(dir_.file("m.db"));
    ASSERT_TRUE(db);
    auto s = sample_session(1);
    s.site = "forearm";
    s.model = "extended";
    const auto sid = db->create_session(s);
    ASSERT_TRUE(sid);
    auto measurement = sample_measurement(*sid, 1);
    measurement.reflectance = {grid(), skin_like()};
    auto recorded = db->record_measurement(measurement, std::nullopt);
    ASSERT_TRUE(recorded);
    m = recorded->measurement_id;
  }
  Daemon d(dir_.file("m.db"));
  ASSERT_NE(d.port(), 0) << d.process().err();
  const std::string path = "/api/v1/measurements/" + std::to_string(m);
  ASSERT_EQ(http_request(d.port(), "GET", path).status, 200);
  const auto refit = http_request(d.port(), "POST", path + "/fit", json{{"lateral_diffusion", false}}.dump());
  ASSERT_EQ(refit.status, 201) << refit.body;
  const auto fit =
      http_request(d.port(), "GET", "/api/v1/fits/" + std::to_string(refit.json()["id"].get<std::int64_t>()));
  ASSERT_EQ(fit.status, 200);
  EXPECT_EQ(fit.json()["params"], refit.json()["params"]);
  EXPECT_EQ(http_request(d.port(), "GET", path).json()["fit_id"], refit.json()["id"]);
  expect_error(http_request(d.port(), "POST", path + "/fit", json{{"site", "knee"}}.dump()), 422, "unknown_site");
}

// `skinspec export` and the service show each stored record with the same fields and values:
// the white standard, the session, a measurement (its raw reply not UTF-8), its fits (one
// stored with it, one the service refitted) and a rejected reading.
TEST_F(DaemonTest, TheExportShowsEachRecordAsTheServiceDoes) {
  const std::string path = dir_.file("records.db");
  store::Id session = 0, measurement = 0, ws = 0;
  {
    auto db = store::Store::open(path);
    ASSERT_TRUE(db) << db.error().message;
    ws = db->add_white_standard(sample_white_standard(1)).value();
    auto s = sample_session(0);
    s.white_standard_id = ws;
    session = db->create_session(s).value();
    auto m = sample_measurement(session, 1);
    m.reflectance = {grid(), skin_like()};
    measurement = db->record_measurement(m, sample_fit(1)).value().measurement_id;
    store::RejectedReading rejected;
    rejected.session_id = session;
    rejected.quality_code = 19;
    rejected.quality = "overload";
    rejected.reason = "bad_reading: quality 19";
    rejected.raw_reply = "19,0\r\n\xff";
    ASSERT_TRUE(db->record_rejected_reading(rejected));
  }
  Daemon d(path);
  ASSERT_NE(d.port(), 0) << d.process().err();
  const auto p = d.port();
  const auto refit = http_request(p, "POST", "/api/v1/measurements/" + std::to_string(measurement) + "/fit", "{}");
  ASSERT_EQ(refit.status, 201) << refit.body;

  // Beside the running service, as a lab would.
  const auto exported = run_process(std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec",
                                    {"export", "--db", path, "--session", std::to_string(session)});
  ASSERT_EQ(exported.exit_status, 0) << exported.describe();
  const json line = json::parse(exported.out);
  ASSERT_EQ(line["measurements"].size(), 1u) << line;
  json m = line["measurements"][0];
  ASSERT_EQ(m["fits"].size(), 2u) << m;
  for (const auto& fit : m["fits"]) {
    const auto served = http_request(p, "GET", "/api/v1/fits/" + std::to_string(fit["id"].get<store::Id>())).json();
    EXPECT_EQ(fit, served);
    for (const auto& field : served.items()) EXPECT_EQ(fit[field.key()], field.value()) << field.key();
  }
  EXPECT_EQ(m["fits"][1], refit.json());
  const json fits = m["fits"];
  m.erase("fits");
  json served_measurement = http_request(p, "GET", "/api/v1/measurements/" + std::to_string(measurement)).json();
  served_measurement.erase("colour");  // computed for the answer, not stored
  EXPECT_EQ(m, served_measurement);
  EXPECT_EQ(line["white_standard"], http_request(p, "GET", "/api/v1/white-standards/" + std::to_string(ws)).json());

  const json detail = http_request(p, "GET", "/api/v1/sessions/" + std::to_string(session)).json();
  for (const auto& field : line["session"].items()) EXPECT_EQ(detail[field.key()], field.value()) << field.key();
  EXPECT_EQ(detail["fits"], fits);
  EXPECT_EQ(detail["measurements"][0], served_measurement);
  EXPECT_EQ(detail["rejected_readings"], line["rejected_readings"]);
  EXPECT_EQ(line["rejected_readings"][0]["raw_reply_base64"], "MTksMA0K/w==");  // "19,0\r\n\xff"
}

// The version set in CMake's project() is what every program and the service report.
TEST_F(DaemonTest, EveryProgramReportsTheOneVersion) {
  const std::string version(kVersion);
  for (const std::string program : {"skinspecd", "skinspec", "skinspec-sim"}) {
    const auto shown = run_process(std::string(SKINSPEC_TEST_BIN_DIR) + "/" + program, {"--version"});
    EXPECT_EQ(shown.exit_status, 0) << shown.describe();
    EXPECT_EQ(shown.out, program + " " + version + "\n");
  }
  Daemon d(dir_.file("v.db"));
  ASSERT_NE(d.port(), 0) << d.process().err();
  EXPECT_EQ(http_request(d.port(), "GET", "/healthz").json()["version"], version);
  EXPECT_EQ(http_request(d.port(), "GET", "/openapi.json").json()["info"]["version"], version);
}

TEST_F(DaemonTest, BadInputOnTheWireGetsJsonErrorsAndTheServerKeepsServing) {
  Daemon d(dir_.file("bad.db"), {"--body-limit", "4096"});
  ASSERT_NE(d.port(), 0) << d.process().err();
  const auto p = d.port();
  expect_error(http_request(p, "POST", "/api/v1/fit", "{not json"), 400, "malformed_json");
  expect_error(http_request(p, "POST", "/api/v1/fit", "{\"site\":\"\xff\"}"), 400, "invalid_utf8");
  expect_error(http_request(p, "POST", "/api/v1/fit", "{}", {{"Content-Type", "text/csv"}}), 415,
               "unsupported_media_type");
  expect_error(http_request(p, "POST", "/api/v1/fit",
                            json{{"wavelength_nm", {400, 500, 600}}, {"reflectance", {0.1, 0.2}}}.dump()),
               422, "unequal_lengths");
  expect_error(http_request(p, "POST", "/api/v1/fit", json{{"wavelength_nm", "x"}, {"reflectance", {0.1}}}.dump()), 422,
               "wrong_type");
  expect_error(http_request(p, "POST", "/api/v1/sessions", json{{"subject", "x"}}.dump()), 422, "missing_field");
  expect_error(http_request(p, "POST", "/api/v1/fit", "{\"wavelength_nm\":[1e300,2],\"reflectance\":[0,0]}"), 422,
               "out_of_range");
  expect_error(http_request(p, "POST", "/api/v1/fit", std::string(5000, ' ')), 413, "payload_too_large");
  expect_error(http_request(p, "GET", "/api/v2/everything"), 404, "not_found");
  const auto method = http_request(p, "DELETE", "/api/v1/fit");
  expect_error(method, 405, "method_not_allowed");
  EXPECT_EQ(method.header("allow"), "POST");
  const std::string traversal =
      raw_exchange(p, "GET /api/v1/../../etc/passwd HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", 10s);
  EXPECT_EQ(traversal.rfind("HTTP/1.1 400", 0), 0u) << traversal;
  EXPECT_NE(traversal.find("invalid_path"), std::string::npos);
  const std::string bad_utf8 =
      raw_exchange(p, "GET /api/v1/fits/\xc0\xaf HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", 10s);
  EXPECT_NE(bad_utf8.find("invalid_path"), std::string::npos) << bad_utf8;
  const std::string garbage = raw_exchange(p, "HELLO\r\n\r\n", 10s);
  EXPECT_EQ(garbage.rfind("HTTP/1.1 400", 0), 0u) << garbage;
  const std::string big_headers =
      raw_exchange(p, "GET /healthz HTTP/1.1\r\nX-A: " + std::string(20000, 'a') + "\r\n\r\n", 10s);
  EXPECT_EQ(big_headers.rfind("HTTP/1.1 413", 0), 0u) << big_headers.substr(0, 200);
  EXPECT_EQ(http_request(p, "GET", "/healthz").status, 200);
}

TEST_F(DaemonTest, SlowClientsAreCutOffWhileOthersAreServed) {
  Daemon d(dir_.file("slow.db"), {"--read-timeout-ms", "700"});
  ASSERT_NE(d.port(), 0) << d.process().err();
  namespace asio = boost::asio;
  asio::io_context ioc;
  asio::ip::tcp::socket slow(ioc);
  slow.connect({asio::ip::make_address("127.0.0.1"), d.port()});
  asio::write(slow, asio::buffer(std::string("GET /healthz HTTP/1.1\r\nHost: x\r\n")));  // never finished
  asio::ip::tcp::socket idle(ioc);
  idle.connect({asio::ip::make_address("127.0.0.1"), d.port()});  // sends nothing at all
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(http_request(d.port(), "GET", "/healthz").status, 200);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 600ms);
  for (auto* socket : {&slow, &idle}) {
    char byte = 0;
    boost::system::error_code ec;
    socket->read_some(asio::buffer(&byte, 1), ec);  // returns when the server closes it
    EXPECT_TRUE(ec) << "the server should have closed the connection";
  }
  EXPECT_GE(std::chrono::steady_clock::now() - start, 500ms);
  EXPECT_EQ(http_request(d.port(), "GET", "/healthz").status, 200);
}

TEST_F(DaemonTest, KeepAliveServesManyRequestsOnOneConnection) {
  Daemon d(dir_.file("ka.db"));
  ASSERT_NE(d.port(), 0) << d.process().err();
  HttpConnection c(d.port());
  for (int i = 0; i < 20; ++i) ASSERT_EQ(c.request("GET", "/healthz").status, 200) << i;
}

TEST_F(DaemonTest, OffLoopbackNeedsAPrivateTokenFile) {
  const auto refused = run_process(kDaemon, {"--listen", "0.0.0.0:0", "--db", dir_.file("t.db")},
                                   {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  EXPECT_EQ(refused.exit_status, 2) << refused.describe();
  EXPECT_NE(refused.err.find("token"), std::string::npos);
  const std::string tokens = dir_.file("tokens.json");
  std::ofstream(tokens) << R"({"read_token": "read-0123456789abcdef", "operator_token": "oper-0123456789abcdef"})";
  ::chmod(tokens.c_str(), 0644);
  const auto open_file =
      run_process(kDaemon, {"--listen", "0.0.0.0:0", "--db", dir_.file("t.db"), "--token-file", tokens},
                  {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  EXPECT_EQ(open_file.exit_status, 2) << open_file.describe();
  EXPECT_NE(open_file.err.find("chmod 600"), std::string::npos) << open_file.err;
  ::chmod(tokens.c_str(), 0600);
  BackgroundProcess d(
      kDaemon, {"--listen", "0.0.0.0:0", "--db", dir_.file("t.db"), "--token-file", tokens, "--upload-limit", "1000"});
  const auto line = d.wait_for_stdout_line("skinspecd listening on http://0.0.0.0:", 30s);
  ASSERT_TRUE(line) << d.err();
  const auto port = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
  EXPECT_EQ(http_request(port, "GET", "/healthz").status, 200);
  expect_error(http_request(port, "GET", "/api/v1/sessions"), 401, "unauthorized");
  const std::string session = json{{"site", "forearm"}, {"subject", "S"}}.dump();
  EXPECT_EQ(
      http_request(port, "GET", "/api/v1/sessions", "", {{"Authorization", "Bearer read-0123456789abcdef"}}).status,
      200);
  expect_error(
      http_request(port, "POST", "/api/v1/sessions", session, {{"Authorization", "Bearer read-0123456789abcdef"}}), 403,
      "forbidden");
  EXPECT_EQ(http_request(port, "POST", "/api/v1/sessions", session, {{"Authorization", "Bearer oper-0123456789abcdef"}})
                .status,
            201);
  // A file to import is refused for its token from the header, before its body is taken in:
  // 403 rather than the 413 its size would earn, and 413 with the operator's token.
  const std::string file(5000, 'x');
  const auto with = [&](const std::string& token) {
    return std::vector<std::pair<std::string, std::string>>{{"Content-Type", "text/csv"},
                                                            {"Authorization", "Bearer " + token}};
  };
  expect_error(http_request(port, "POST", "/api/v1/sessions/1/imports", file, with("read-0123456789abcdef")), 403,
               "forbidden");
  expect_error(http_request(port, "POST", "/api/v1/sessions/1/imports", file, {{"Content-Type", "text/csv"}}), 401,
               "unauthorized");
  expect_error(http_request(port, "POST", "/api/v1/sessions/1/imports", file, with("oper-0123456789abcdef")), 413,
               "payload_too_large");
  d.send_signal(SIGTERM);
  EXPECT_EQ(d.wait(30s).exit_status, 0);
}

TEST_F(DaemonTest, ConfigFileSetsOptionsAndFlagsWin) {
  const std::string config = dir_.file("config.json");
  std::ofstream(config) << R"({"db": ")" << dir_.file("from-config.db")
                        << R"(", "body_limit": 100, "log_level": "warn"})";
  Daemon d(dir_.file("flag.db"), {"--config", config});
  ASSERT_NE(d.port(), 0) << d.process().err();
  EXPECT_NE(http_request(d.port(), "GET", "/healthz").json()["database"]["path"].get<std::string>().find("flag.db"),
            std::string::npos);
  expect_error(http_request(d.port(), "POST", "/api/v1/fit", std::string(200, ' ')), 413, "payload_too_large");
  d.stop();
  std::ofstream(config) << R"({"listen": 5})";
  const auto bad = run_process(kDaemon, {"--config", config}, {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  EXPECT_EQ(bad.exit_status, 2) << bad.describe();
}

// A bench name that is not one, or a lease out of range, as a flag or in the config file: exit
// 2 naming it, before any database is made; so is any flag CLI11 refuses.
TEST_F(DaemonTest, ABadBenchOrLeaseIsABadOption) {
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.end(), {"--db", dir_.file("b.db"), "--device", "tcp:127.0.0.1:9"});
    return run_process(kDaemon, args, {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  };
  const auto spaced = run({"--bench", "bench one"});
  EXPECT_EQ(spaced.exit_status, 2) << spaced.describe();
  EXPECT_NE(spaced.err.find("--bench: 'bench one' is not 1-64 letters"), std::string::npos) << spaced.err;
  EXPECT_EQ(run({"--bench", std::string(65, 'b')}).exit_status, 2);
  const auto short_lease = run({"--lease", "1"});
  EXPECT_EQ(short_lease.exit_status, 2) << short_lease.describe();
  EXPECT_NE(short_lease.err.find("--lease"), std::string::npos) << short_lease.err;
  EXPECT_EQ(run({"--threads", "0"}).exit_status, 2);
  EXPECT_EQ(run({"--io-threads", "0"}).exit_status, 2);
  const std::string config = dir_.file("bench.json");
  std::ofstream(config) << R"({"io_threads": 0})";
  const auto no_io_thread = run({"--config", config});
  EXPECT_EQ(no_io_thread.exit_status, 2) << no_io_thread.describe();
  EXPECT_NE(no_io_thread.err.find("io_threads 0 is not 1-64"), std::string::npos) << no_io_thread.err;
  std::ofstream(config) << R"({"bench": "a/b", "lease": 15})";
  EXPECT_EQ(run({"--config", config}).exit_status, 2);
  std::ofstream(config) << R"({"lease": 9999})";
  EXPECT_EQ(run({"--config", config}).exit_status, 2);
  std::ofstream(config) << R"({"lease_s": 15})";
  const auto unknown = run({"--config", config});
  EXPECT_EQ(unknown.exit_status, 2) << unknown.describe();
  EXPECT_NE(unknown.err.find("unknown config key 'lease_s'"), std::string::npos) << unknown.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.file("b.db")));
  EXPECT_EQ(run_process(kDaemon, {"--version"}, {.stdin_bytes = {}, .timeout = 30s, .environment = {}}).exit_status, 0);
}

// A model skinspec does not know, as a flag or in the config file, is a bad option: exit 2 with
// the models it knows, before any database is made.
TEST_F(DaemonTest, AnUnknownModelIsABadOption) {
  const auto flag = run_process(kDaemon, {"--db", dir_.file("m.db"), "--device", "tcp:127.0.0.1:9", "--model", "pr999"},
                                {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  EXPECT_EQ(flag.exit_status, 2) << flag.describe();
  EXPECT_NE(flag.err.find("--model: unknown model 'pr999' (one of: auto, pr650, pr655, pr670"), std::string::npos)
      << flag.err;
  const std::string config = dir_.file("model.json");
  std::ofstream(config) << R"({"model": "PR-670"})";
  const auto configured = run_process(kDaemon, {"--db", dir_.file("m.db"), "--config", config},
                                      {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
  EXPECT_EQ(configured.exit_status, 2) << configured.describe();
  EXPECT_NE(configured.err.find("unknown model 'PR-670'"), std::string::npos) << configured.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.file("m.db")));
  std::ofstream(config) << R"({"model": 670})";
  EXPECT_EQ(run_process(kDaemon, {"--db", dir_.file("m.db"), "--config", config},
                        {.stdin_bytes = {}, .timeout = 30s, .environment = {}})
                .exit_status,
            2);
}

TEST_F(DaemonTest, SigtermFinishesTheRequestInFlight) {
  Daemon d(dir_.file("stop.db"));
  ASSERT_NE(d.port(), 0) << d.process().err();
  json spectra = json::object();
  for (int i = 0; i < 20; ++i) spectra["s" + std::to_string(i)] = skin_like();
  HttpReply reply;
  std::thread client([&] {
    reply = http_request(d.port(), "POST", "/api/v1/fit", json{{"wavelength_nm", grid()}, {"spectra", spectra}}.dump());
  });
  std::this_thread::sleep_for(100ms);
  d.process().send_signal(SIGTERM);
  client.join();
  EXPECT_EQ(reply.status, 200) << reply.error;
  const auto ended = d.process().wait(30s);
  EXPECT_EQ(ended.exit_status, 0) << ended.describe();
}

}  // namespace
}  // namespace skinspec::testing
