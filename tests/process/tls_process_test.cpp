// HTTPS on a real skinspecd (--tls-cert, --tls-key) with curl and skinspec as its clients, and
// certificates made here with the openssl program: a throwaway CA's for 127.0.0.1 and an
// unrelated CA. A client trusting the right CA (curl --cacert, skinspec --ca-file) gets answers
// and a job's Server-Sent Events; trusting the wrong one it fails verification and gets nothing;
// plain HTTP or garbage on the port closes that connection and nothing else; a client that never
// handshakes is held to the read timeout and gives way to a newcomer like any idle connection;
// bad TLS settings stop skinspecd before it listens.

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

const std::string kDaemon = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd";
const std::string kSkinspec = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec";

// curl's exit status when the server's certificate does not verify.
constexpr int kCurlBadCertificate = 60;
// ... and when the handshake fails.
constexpr int kCurlHandshakeFailed = 35;

ProcessResult openssl(const std::vector<std::string>& args) {
  return run_process(SKINSPEC_TEST_OPENSSL, args, {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
}

// The files of a throwaway PKI in `dir`: a CA, a server certificate it signed for 127.0.0.1,
// and a CA that signed nothing of ours.
struct Pki {
  std::string ca, server_cert, server_key, other_ca, other_ca_key;
};

// A self-signed CA certificate (P-256, for a day) and its key.
void make_ca(const ScratchDirectory& dir, const std::string& name) {
  const auto made =
      openssl({"req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes", "-keyout",
               dir.file(name + ".key"), "-out", dir.file(name + ".pem"), "-days", "1", "-subj", "/CN=" + name});
  ASSERT_EQ(made.exit_status, 0) << made.describe();
}

// A server certificate for 127.0.0.1 that the CA `ca` (made by make_ca) signed, and its new key.
void make_server_certificate(const ScratchDirectory& dir, const std::string& ca, const std::string& cert,
                             const std::string& key) {
  const auto request = openssl({"req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes", "-keyout", key,
                                "-out", dir.file("server.csr"), "-subj", "/CN=127.0.0.1"});
  EXPECT_EQ(request.exit_status, 0) << request.describe();
  // Clients check the address they connect to against the subject alternative names.
  std::ofstream(dir.file("server.ext")) << "subjectAltName=IP:127.0.0.1\nbasicConstraints=CA:FALSE\n"
                                           "extendedKeyUsage=serverAuth\n";
  const auto signed_ = openssl({"x509", "-req", "-in", dir.file("server.csr"), "-CA", dir.file(ca + ".pem"), "-CAkey",
                                dir.file(ca + ".key"), "-CAcreateserial", "-out", cert, "-days", "1", "-extfile",
                                dir.file("server.ext")});
  EXPECT_EQ(signed_.exit_status, 0) << signed_.describe();
}

Pki make_pki(const ScratchDirectory& dir) {
  Pki pki{dir.file("ca.pem"), dir.file("server.pem"), dir.file("server.key"), dir.file("other_ca.pem"),
          dir.file("other_ca.key")};
  make_ca(dir, "ca");
  make_ca(dir, "other_ca");
  make_server_certificate(dir, "ca", pki.server_cert, pki.server_key);
  return pki;
}

// curl with `args`, quiet but for errors, bounded in time.
ProcessResult curl(std::vector<std::string> args) {
  args.insert(args.begin(), {"--silent", "--show-error", "--max-time", "30"});
  return run_process(SKINSPEC_TEST_CURL, args, {.stdin_bytes = {}, .timeout = 60s, .environment = {}});
}

std::string https(unsigned short port, const std::string& target) {
  return "https://127.0.0.1:" + std::to_string(port) + target;
}

struct CurlReply {
  ProcessResult process;
  int status = 0;
  std::string body;
};

// `method target` over HTTPS trusting `ca`; the status and the body, apart.
CurlReply request(const std::string& ca, unsigned short port, const std::string& method, const std::string& target,
                  const std::string& body = "") {
  std::vector<std::string> args = {"--cacert", ca, "-X", method, "--write-out", "\n%{http_code}"};
  if (!body.empty()) args.insert(args.end(), {"-H", "Content-Type: application/json", "--data-binary", body});
  args.push_back(https(port, target));
  CurlReply reply{curl(args), 0, {}};
  const auto last = reply.process.out.rfind('\n');
  if (reply.process.exit_status != 0 || last == std::string::npos) return reply;
  reply.status = std::stoi(reply.process.out.substr(last + 1));
  reply.body = reply.process.out.substr(0, last);
  return reply;
}

// The "data:" of each event in a Server-Sent Events stream.
std::vector<json> event_data(const std::string& stream) {
  std::vector<json> events;
  for (const auto& line : lines_of(stream))
    if (line.rfind("data: ", 0) == 0) events.push_back(json::parse(line.substr(6), nullptr, false));
  return events;
}

struct Silent {
  std::string received;
  bool closed = false;  // by the server, before `limit`
  std::chrono::steady_clock::duration held{};
};

// Connects to `port`, sends `bytes` (not a TLS handshake), and reads until the server closes
// the connection or `limit` passes. Blocking reads with a kernel timeout: Beast's timeouts hold
// only for asynchronous operations, and a test waiting for a server that never closes must end.
Silent stay_silent(unsigned short port, const std::string& bytes, std::chrono::seconds limit) {
  Silent out;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return out;
  const timeval timeout{static_cast<time_t>(limit.count()), 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const auto start = std::chrono::steady_clock::now();
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0 &&
      (bytes.empty() || ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size()))) {
    char chunk[4096];
    ssize_t n = 0;
    while ((n = ::recv(fd, chunk, sizeof chunk, 0)) > 0) out.received.append(chunk, static_cast<std::size_t>(n));
    out.closed = n == 0 || errno == ECONNRESET;
  }
  out.held = std::chrono::steady_clock::now() - start;
  ::close(fd);
  return out;
}

unsigned short port_of(const std::string& line) {
  return static_cast<unsigned short>(std::stoi(line.substr(line.rfind(':') + 1)));
}

class TlsProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    pki_ = make_pki(dir_);
    ASSERT_FALSE(::testing::Test::HasFailure());
  }
  std::vector<std::string> tls_args() const { return {"--tls-cert", pki_.server_cert, "--tls-key", pki_.server_key}; }

  // skinspecd without a meter on HTTPS, with `more` flags; its port (0 when it did not come up).
  unsigned short start_daemon(const std::vector<std::string>& more) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--db", dir_.file("tls.db")};
    args.insert(args.end(), more.begin(), more.end());
    daemon_ = std::make_unique<BackgroundProcess>(kDaemon, args);
    const auto line = daemon_->wait_for_stdout_line("skinspecd listening on https://127.0.0.1:", 30s);
    return line ? port_of(*line) : 0;
  }

  ScratchDirectory dir_;
  Pki pki_;
  std::unique_ptr<BackgroundProcess> daemon_;
};

TEST_F(TlsProcessTest, TheRightCaVerifiesTheWrongOneFailsAndPlainHttpIsTurnedAway) {
  auto options = rig_options(dir_.path().string(), 0.05);
  options.daemon_args = tls_args();
  AcquisitionRig rig(options);
  ASSERT_TRUE(rig.ready()) << rig.logs();
  EXPECT_NE(rig.daemon->out().find("skinspecd listening on https://127.0.0.1:"), std::string::npos)
      << rig.daemon->out();
  EXPECT_TRUE(rig.daemon->wait_for_stderr("event=listening scheme=https ", 5s)) << rig.logs();
  const auto p = rig.port;

  const auto healthy = request(pki_.ca, p, "GET", "/healthz");
  ASSERT_EQ(healthy.process.exit_status, 0) << healthy.process.describe();
  EXPECT_EQ(healthy.status, 200) << healthy.body;
  EXPECT_TRUE(json::parse(healthy.body, nullptr, false).is_object()) << healthy.body;

  // A client that trusts another CA refuses the server before sending its request.
  const auto wrong = curl({"--cacert", pki_.other_ca, https(p, "/healthz")});
  EXPECT_EQ(wrong.exit_status, kCurlBadCertificate) << wrong.describe();
  EXPECT_TRUE(wrong.out.empty()) << wrong.out;

  // TLS 1.1 and older are not offered.
  const auto old = curl({"--cacert", pki_.ca, "--tlsv1.1", "--tls-max", "1.1", https(p, "/healthz")});
  EXPECT_EQ(old.exit_status, kCurlHandshakeFailed) << old.describe();
  EXPECT_TRUE(old.out.empty()) << old.out;

  // Plain HTTP and garbage: no HTTP answer, the connection closed, the service unharmed.
  const auto plain = curl({"http://127.0.0.1:" + std::to_string(p) + "/healthz"});
  EXPECT_NE(plain.exit_status, 0) << plain.describe();
  EXPECT_EQ(plain.out.find("HTTP/1.1"), std::string::npos) << plain.out;
  const auto garbage = stay_silent(p, std::string(300, '\x16') + "\r\n\r\n", 10s);
  EXPECT_TRUE(garbage.closed);
  EXPECT_EQ(garbage.received.find("HTTP/"), std::string::npos) << garbage.received;
  EXPECT_FALSE(rig.daemon->has_exited()) << rig.logs();
  EXPECT_EQ(request(pki_.ca, p, "GET", "/healthz").status, 200);

  // A measurement's events stream over TLS from its start to its end.
  const auto session =
      request(pki_.ca, p, "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}}.dump());
  ASSERT_EQ(session.status, 201) << session.body;
  const auto job =
      request(pki_.ca, p, "POST",
              "/api/v1/sessions/" + std::to_string(json::parse(session.body)["id"].get<long long>()) + "/measurements",
              json{{"kind", "white"}, {"count", 3}}.dump());
  ASSERT_EQ(job.status, 202) << job.body;
  const auto events =
      curl({"--no-buffer", "--cacert", pki_.ca,
            https(p, "/api/v1/jobs/" + std::to_string(json::parse(job.body)["job_id"].get<long long>()) + "/events")});
  ASSERT_EQ(events.exit_status, 0) << events.describe();
  const auto seen = event_data(events.out);
  ASSERT_GE(seen.size(), 2u) << events.out;
  EXPECT_NE(seen.front()["state"], "succeeded") << events.out;
  EXPECT_EQ(seen.back()["state"], "succeeded") << events.out << rig.logs();

  // skinspec over HTTPS: a measurement followed by its events; the wrong CA gets exit 4.
  const auto skinspec = [&](const std::string& ca, std::vector<std::string> args) {
    args.insert(args.end(), {"--server", https(p, ""), "--ca-file", ca});
    return run_process(kSkinspec, args, {.stdin_bytes = {}, .timeout = 60s, .environment = {}});
  };
  const auto opened = skinspec(pki_.ca, {"session", "new", "--site", "forearm", "--json"});
  ASSERT_EQ(opened.exit_status, 0) << opened.describe();
  const std::string id = std::to_string(json::parse(opened.out)["id"].get<long long>());
  const auto measured = skinspec(pki_.ca, {"session", "measure", id, "--kind", "white", "--count", "2", "--json"});
  EXPECT_EQ(measured.exit_status, 0) << measured.describe();
  const auto refused = skinspec(pki_.other_ca, {"session", "show", id});
  EXPECT_EQ(refused.exit_status, 4) << refused.describe();
  EXPECT_NE(refused.err.find("certificate verify failed"), std::string::npos) << refused.err;
  const auto unreadable = skinspec(dir_.file("missing.pem"), {"session", "show", id});
  EXPECT_EQ(unreadable.exit_status, 2) << unreadable.describe();
}

// The handshake has the time a request has: a client that connects and sends nothing, or half
// a TLS record, is closed after --read-timeout-ms without a byte.
TEST_F(TlsProcessTest, AClientThatNeverHandshakesIsClosedAfterTheReadTimeout) {
  auto args = tls_args();
  args.insert(args.end(), {"--read-timeout-ms", "700"});
  const auto p = start_daemon(args);
  ASSERT_NE(p, 0) << daemon_->err();
  for (const std::string& sent : {std::string(), std::string("\x16\x03\x01\x02\x00", 5)}) {
    const auto silent = stay_silent(p, sent, 10s);
    EXPECT_TRUE(silent.closed);
    EXPECT_TRUE(silent.received.empty()) << silent.received;
    EXPECT_GE(silent.held, 600ms);
    EXPECT_LT(silent.held, 5s);
  }
  EXPECT_EQ(request(pki_.ca, p, "GET", "/healthz").status, 200);
}

// The connection limits count a connection in its handshake as idle: a newcomer displaces it.
TEST_F(TlsProcessTest, AConnectionThatNeverHandshakesGivesWayToANewcomer) {
  auto args = tls_args();
  args.insert(args.end(), {"--max-connections-per-client", "1"});
  const auto p = start_daemon(args);
  ASSERT_NE(p, 0) << daemon_->err();
  auto silent = std::async(std::launch::async, [p] { return stay_silent(p, "", 10s); });
  std::this_thread::sleep_for(300ms);  // admitted before the newcomer
  EXPECT_EQ(request(pki_.ca, p, "GET", "/healthz").status, 200);
  const auto displaced = silent.get();
  EXPECT_TRUE(displaced.closed);
  EXPECT_LT(displaced.held, 5s) << "the silent connection was kept";
}

// Each stops skinspecd with status 2 before it listens, saying why.
TEST_F(TlsProcessTest, BadTlsSettingsStopTheDaemonBeforeItListens) {
  std::ofstream(dir_.file("not_a_certificate.pem")) << "-----BEGIN CERTIFICATE-----\nnonsense\n";
  const std::string config = dir_.file("half.json");
  std::ofstream(config) << json{{"tls_cert", pki_.server_cert}}.dump();
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--tls-cert", pki_.server_cert}, "--tls-cert needs --tls-key"},
      {{"--tls-key", pki_.server_key}, "--tls-key needs --tls-cert"},
      {{"--config", config}, "--tls-cert needs --tls-key"},
      {{"--tls-cert", dir_.file("missing.pem"), "--tls-key", pki_.server_key}, "cannot read the file"},
      {{"--tls-cert", dir_.file("not_a_certificate.pem"), "--tls-key", pki_.server_key}, "no PEM certificate"},
      {{"--tls-cert", pki_.server_cert, "--tls-key", pki_.server_cert}, "no usable PEM private key"},
      {{"--tls-cert", pki_.server_cert, "--tls-key", pki_.other_ca_key}, "not the private key of the certificate"},
  };
  for (const auto& [flags, message] : cases) {
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--db", dir_.file("bad.db")};
    args.insert(args.end(), flags.begin(), flags.end());
    const auto r = run_process(kDaemon, args, {.stdin_bytes = {}, .timeout = 20s, .environment = {}});
    EXPECT_EQ(r.exit_status, 2) << r.describe();
    EXPECT_NE(r.err.find(message), std::string::npos) << message << "\n" << r.err;
    EXPECT_EQ(r.out.find("listening"), std::string::npos) << r.out;
  }
}

// A renewed certificate (here from another CA, so that the tests can tell which one is served)
// is written over the files and taken up on SIGHUP, not before; files that fail the checks on
// SIGHUP leave the certificate served as it was.
TEST_F(TlsProcessTest, SighupServesARenewedCertificateAndKeepsTheOldOneWhenTheNewFilesAreBad) {
  const std::string cert = dir_.file("live.pem"), key = dir_.file("live.key");
  std::filesystem::copy_file(pki_.server_cert, cert);
  std::filesystem::copy_file(pki_.server_key, key);
  const auto p = start_daemon({"--tls-cert", cert, "--tls-key", key});
  ASSERT_NE(p, 0) << daemon_->err();
  const auto served_by = [&](const std::string& ca) { return curl({"--cacert", ca, https(p, "/healthz")}); };
  ASSERT_EQ(served_by(pki_.ca).exit_status, 0);

  make_server_certificate(dir_, "other_ca", cert, key);
  EXPECT_EQ(served_by(pki_.ca).exit_status, 0) << "read again only on SIGHUP";
  daemon_->send_signal(SIGHUP);
  ASSERT_TRUE(daemon_->wait_for_stderr("event=tls_reloaded reload=1 ", 20s)) << daemon_->err();
  EXPECT_EQ(served_by(pki_.other_ca).exit_status, 0) << served_by(pki_.other_ca).describe();
  EXPECT_EQ(served_by(pki_.ca).exit_status, kCurlBadCertificate);

  std::ofstream(cert, std::ios::trunc) << "-----BEGIN CERTIFICATE-----\nnonsense\n";
  daemon_->send_signal(SIGHUP);
  ASSERT_TRUE(daemon_->wait_for_stderr("event=tls_reload_failed reload=2 ", 20s)) << daemon_->err();
  EXPECT_NE(daemon_->err().find("no PEM certificate"), std::string::npos) << daemon_->err();
  EXPECT_EQ(served_by(pki_.other_ca).exit_status, 0) << "the certificate served before is kept";
  EXPECT_FALSE(daemon_->has_exited());
}

// The config file names them as it names the other flags.
TEST_F(TlsProcessTest, TheConfigFileTurnsHttpsOn) {
  const std::string config = dir_.file("tls.json");
  std::ofstream(config) << json{{"tls_cert", pki_.server_cert}, {"tls_key", pki_.server_key}}.dump();
  const auto p = start_daemon({"--config", config});
  ASSERT_NE(p, 0) << daemon_->err();
  EXPECT_EQ(request(pki_.ca, p, "GET", "/healthz").status, 200);
}

}  // namespace
}  // namespace skinspec::testing
