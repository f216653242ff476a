// A real skinspecd on loopback under hostile HTTP: request framing that could smuggle a second
// request, HEAD, running out of file descriptors, heavy fits beside /healthz, and floods of
// idle connections from one client.

#include <gtest/gtest.h>
#include <zlib.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <future>
#include <sstream>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>

#include "skinspec/client/http_client.hpp"
#include "support/raw_exchange.hpp"
#include "skinspec/testkit/process.hpp"
#include "support/service_processes.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const std::string kBin = SKINSPEC_TEST_BIN_DIR;

void expect_json_error(const HttpReply& r, int status, const std::string& code) {
  EXPECT_EQ(r.status, status) << r.body << r.error;
  const json b = r.json();
  ASSERT_TRUE(b.is_object() && b.contains("error")) << r.body;
  EXPECT_EQ(b["error"]["code"], code) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/json");
}

// Sockets connected to the daemon that send nothing, from `source` (an address of 127/8).
class IdleClients {
 public:
  void open(unsigned short port, std::size_t n, const std::string& source = "127.0.0.1") {
    for (std::size_t i = 0; i < n; ++i) {
      tcp::socket s(ioc_);
      s.open(tcp::v4());
      s.bind({asio::ip::make_address(source), 0});
      s.connect({asio::ip::make_address("127.0.0.1"), port});
      sockets_.push_back(std::move(s));
    }
  }
  std::size_t size() const { return sockets_.size(); }
  // Whether the server has closed socket `i` (reading it ends), waiting up to `timeout`.
  bool closed_by_server(std::size_t i, std::chrono::milliseconds timeout) {
    auto& s = sockets_.at(i);
    s.non_blocking(true);
    const auto deadline = Clock::now() + timeout;
    do {
      char byte = 0;
      boost::system::error_code ec;
      s.read_some(asio::buffer(&byte, 1), ec);
      if (ec && ec != asio::error::would_block) return true;
      std::this_thread::sleep_for(10ms);
    } while (Clock::now() < deadline);
    return false;
  }
  tcp::socket& at(std::size_t i) { return sockets_.at(i); }

 private:
  asio::io_context ioc_;
  std::vector<tcp::socket> sockets_;
};

// A gauge or counter from /metrics.
double metric(unsigned short port, const std::string& name) {
  const std::string text = http_request(port, "GET", "/metrics").body;
  const auto at = text.find("\n" + name + " ");
  return at == std::string::npos ? -1 : std::stod(text.substr(at + name.size() + 2));
}

// The CPU time the process has used so far (user and system), from /proc/PID/stat.
std::chrono::milliseconds cpu_time(pid_t pid) {
  const auto stat = process_stat(pid);
  return std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(stat ? ticks_to_seconds(stat->own_ticks) : 0.0));
}

std::string healthz_from(const std::string& source, unsigned short port) {
  return raw_exchange_from(source, port, "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", 10s).bytes;
}

class HttpProcessTest : public ::testing::Test {
 protected:
  ListeningProcess start(const std::vector<std::string>& args) {
    auto d = start_daemon(dir_, args);
    EXPECT_NE(d.port, 0) << d.process->err();
    return d;
  }
  ScratchDirectory dir_;
};

TEST_F(HttpProcessTest, EveryTransferEncodingButChunkedAloneIsRefusedAndTheConnectionClosed) {
  auto d = start({});
  ASSERT_NE(d.port, 0);
  const std::string smuggled = "GET /api/v1/sessions HTTP/1.1\r\nHost: x\r\n\r\n";
  const std::vector<std::string> framings = {
      "Transfer-Encoding: gzip\r\n",
      "Transfer-Encoding: identity\r\n",
      "Transfer-Encoding: deflate\r\n",
      "Transfer-Encoding: xchunked\r\n",
      "Transfer-Encoding: chunked, identity\r\n",
      "Transfer-Encoding: gzip, chunked\r\n",
      "Transfer-Encoding: chunked\r\nTransfer-Encoding: chunked\r\n",
      "Transfer-Encoding: gzip\r\nTransfer-Encoding: chunked\r\n",
      "Transfer-Encoding: chunked\r\nContent-Length: 5\r\n",
      "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n",
      "Transfer-Encoding: gzip\r\nContent-Length: 5\r\n",
  };
  for (const auto& framing : framings) {
    SCOPED_TRACE(framing);
    const auto got = raw_exchange_from("127.0.0.1", d.port,
                                       "GET /healthz HTTP/1.1\r\nHost: x\r\n" + framing + "\r\n" + smuggled, 10s);
    EXPECT_TRUE(got.closed) << "the connection should have been closed";
    const auto replies = parse_responses(got.bytes);
    ASSERT_EQ(replies.size(), 1u) << got.bytes;
    expect_json_error(replies[0], 400, "invalid_framing");
    EXPECT_EQ(replies[0].header("connection"), "close");
  }
  const auto old = raw_exchange_from("127.0.0.1", d.port,
                                     "POST /api/v1/fit HTTP/1.0\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n", 10s);
  EXPECT_TRUE(old.closed);
  const auto old_replies = parse_responses(old.bytes);
  ASSERT_EQ(old_replies.size(), 1u) << old.bytes;
  expect_json_error(old_replies[0], 400, "invalid_framing");

  // `chunked` alone is understood, and what follows the last chunk is the next request.
  const std::string session = json{{"site", "forearm"}, {"subject", "S"}}.dump();
  std::ostringstream chunked;
  chunked << "POST /api/v1/sessions HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: "
             "Chunked\r\n\r\n"
          << std::hex << session.size() << "\r\n"
          << session << "\r\n0\r\n\r\n"
          << "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  const auto good = raw_exchange_from("127.0.0.1", d.port, chunked.str(), 10s);
  const auto replies = parse_responses(good.bytes);
  ASSERT_EQ(replies.size(), 2u) << good.bytes;
  EXPECT_EQ(replies[0].status, 201) << replies[0].body;
  EXPECT_EQ(replies[1].status, 200);
  EXPECT_EQ(http_request(d.port, "GET", "/api/v1/sessions").json()["sessions"].size(), 1u);
}

TEST_F(HttpProcessTest, HeadAnswersAsGetWithTheHeadersOnly) {
  auto d = start({});
  ASSERT_NE(d.port, 0);
  const auto get = http_request(d.port, "GET", "/healthz");
  ASSERT_EQ(get.status, 200);
  const auto got = raw_exchange_from("127.0.0.1", d.port,
                                     "HEAD /healthz HTTP/1.1\r\nHost: x\r\n\r\n"
                                     "HEAD /api/v1/fit HTTP/1.1\r\nHost: x\r\n\r\n"
                                     "HEAD /api/v1/sessions/7 HTTP/1.1\r\nHost: x\r\n\r\n"
                                     "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
                                     10s);
  EXPECT_TRUE(got.closed);
  const auto replies = parse_responses(got.bytes, {true, true, true, false});
  ASSERT_EQ(replies.size(), 4u) << got.bytes;
  EXPECT_EQ(replies[0].status, 200);
  EXPECT_EQ(replies[0].header("content-length"), std::to_string(get.body.size()));
  EXPECT_EQ(replies[0].header("content-type"), "application/json");
  EXPECT_TRUE(replies[0].body.empty());
  EXPECT_EQ(replies[1].status, 405);  // POST only
  EXPECT_EQ(replies[1].header("allow"), "POST");
  EXPECT_TRUE(replies[1].body.empty());
  EXPECT_EQ(replies[2].status, 404);
  EXPECT_TRUE(replies[2].body.empty());
  EXPECT_EQ(replies[3].status, 200);
  EXPECT_EQ(replies[3].body, get.body);
  // Had a HEAD answer carried a body, the bytes after the last response would not parse.
  EXPECT_TRUE(replies[3].error.empty()) << replies[3].error;
}

// `gzip` as the inflater of zlib reads it.
std::string gunzip(const std::string& bytes) {
  z_stream stream{};
  if (inflateInit2(&stream, 15 + 16) != Z_OK) return "inflateInit2 failed";
  std::string out(1 << 20, '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  stream.avail_in = static_cast<uInt>(bytes.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&stream, Z_FINISH);
  out.resize(stream.total_out);
  inflateEnd(&stream);
  return status == Z_STREAM_END ? out : "not a whole gzip stream";
}

TEST_F(HttpProcessTest, StoredRecordsAreTaggedRevalidatedWith304AndSentGzipWhenAsked) {
  store::Id session = 0, measurement = 0, fit = 0;
  {
    auto db = store::Store::open(dir_.file("lab.db"));
    ASSERT_TRUE(db) << db.error().message;
    session = *db->create_session(sample_session(1));
    const auto ids = db->record_measurement(sample_measurement(session, 1), sample_fit(1));
    ASSERT_TRUE(ids && ids->fit_id);
    measurement = ids->measurement_id;
    fit = *ids->fit_id;
  }
  auto d = start({});
  ASSERT_NE(d.port, 0);
  for (const auto& [path, cache_control] :
       {std::pair{"/api/v1/fits/" + std::to_string(fit), std::string("public, max-age=31536000, immutable")},
        std::pair{"/api/v1/measurements/" + std::to_string(measurement), std::string("no-cache")}}) {
    SCOPED_TRACE(path);
    const auto plain = http_request(d.port, "GET", path);
    ASSERT_EQ(plain.status, 200) << plain.body;
    EXPECT_TRUE(plain.json().is_object());
    EXPECT_EQ(plain.header("cache-control"), cache_control);
    EXPECT_EQ(plain.header("vary"), "Accept-Encoding");
    EXPECT_EQ(plain.header("content-encoding"), "");
    const std::string etag = plain.header("etag");
    ASSERT_EQ(etag.size(), 18u) << etag;

    const auto unchanged = http_request(d.port, "GET", path, "", {{"If-None-Match", etag}});
    EXPECT_EQ(unchanged.status, 304);
    EXPECT_EQ(unchanged.body, "");
    EXPECT_EQ(unchanged.header("etag"), etag);
    EXPECT_EQ(http_request(d.port, "GET", path, "", {{"If-None-Match", "\"00\""}}).status, 200);

    const auto zipped = http_request(d.port, "GET", path, "", {{"Accept-Encoding", "br, gzip"}});
    ASSERT_EQ(zipped.status, 200);
    EXPECT_EQ(zipped.header("content-encoding"), "gzip");
    EXPECT_LT(zipped.body.size(), plain.body.size());
    EXPECT_EQ(gunzip(zipped.body), plain.body);
    EXPECT_EQ(http_request(d.port, "GET", path, "", {{"Accept-Encoding", "gzip;q=0"}}).body, plain.body);
  }
  // A large answer made for each request (a whole session) is compressed too; a small one is not.
  const auto whole =
      http_request(d.port, "GET", "/api/v1/sessions/" + std::to_string(session), "", {{"Accept-Encoding", "gzip"}});
  ASSERT_EQ(whole.status, 200);
  EXPECT_EQ(whole.header("content-encoding"), "gzip");
  EXPECT_EQ(nlohmann::json::parse(gunzip(whole.body))["id"], session);
  const auto small = http_request(d.port, "GET", "/healthz", "", {{"Accept-Encoding", "gzip"}});
  EXPECT_EQ(small.header("content-encoding"), "");
  EXPECT_TRUE(small.json().is_object());
}

TEST_F(HttpProcessTest, OutOfFileDescriptorsTheDaemonNeitherSpinsNorStopsAnswering) {
  // 200 descriptors for a daemon asked to hold 512 connections, and 400 clients that connect
  // and send nothing.
  const std::vector<std::string> args = {kBin + "/skinspecd",
                                         "--listen",
                                         "127.0.0.1:0",
                                         "--db",
                                         dir_.file("fd.db"),
                                         "--max-connections",
                                         "512",
                                         "--max-connections-per-client",
                                         "512"};
  std::vector<std::string> wrapped = {"200"};
  wrapped.insert(wrapped.end(), args.begin(), args.end());
  BackgroundProcess daemon(kBin + "/limit_open_files", wrapped);
  const auto line = daemon.wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
  ASSERT_TRUE(line) << daemon.err();
  const auto port = port_after_colon(*line);
  ASSERT_TRUE(daemon.wait_for_stderr("event=connection_cap", 5s)) << daemon.err();
  EXPECT_NE(daemon.err().find("open_files_limit=200"), std::string::npos) << daemon.err();

  IdleClients idle;
  idle.open(port, 400);
  std::this_thread::sleep_for(300ms);  // the daemon accepts what it can
  const auto asked = Clock::now();
  const std::string answer = healthz_from("127.0.0.1", port);
  EXPECT_LT(Clock::now() - asked, 2s);
  EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u) << answer;

  const auto before = cpu_time(daemon.pid());
  std::this_thread::sleep_for(1s);
  const auto used = cpu_time(daemon.pid()) - before;
  EXPECT_LT(used, 200ms) << "the daemon used " << used.count() << " ms of CPU in 1 s while idle";
  EXPECT_EQ(healthz_from("127.0.0.2", port).rfind("HTTP/1.1 200", 0), 0u);
  EXPECT_LT(metric(port, "skinspec_open_connections"), 200);
  EXPECT_GT(metric(port, "skinspec_evicted_connections_total"), 0);
  daemon.send_signal(SIGTERM);
  EXPECT_EQ(daemon.wait(30s).exit_status, 0);
}

// A batch fit of `spectra` spectra of 380-780 nm every `step_nm`.
std::string batch_fit_body(int spectra, double step_nm) {
  std::vector<double> wl;
  for (int i = 0; 380 + i * step_nm <= 780; ++i) wl.push_back(380 + i * step_nm);
  json all = json::object();
  for (int i = 0; i < spectra; ++i) {
    std::vector<double> r;
    for (double w : wl) r.push_back(0.2 + 0.0006 * (w - 380) + 0.002 * (i % 13));
    all["s" + std::to_string(i)] = r;
  }
  return json{{"wavelength_nm", wl}, {"spectra", all}}.dump();
}

TEST_F(HttpProcessTest, HealthzStaysFastWhileFitsFillTheComputePoolAndTheOverflowGets503) {
  // Four batch fits of 100 spectra of 1601 samples (half a second or more each, a fit's time
  // growing with its samples; 1.5 MB of JSON): two run, two wait.
  auto d = start({"--compute-threads", "2", "--compute-queue", "2", "--body-limit", "4000000"});
  ASSERT_NE(d.port, 0);
  const std::string body = batch_fit_body(100, 0.25);
  std::vector<std::future<HttpReply>> fits;
  for (int i = 0; i < 4; ++i)
    fits.push_back(std::async(std::launch::async, [&] { return http_request(d.port, "POST", "/api/v1/fit", body); }));
  const auto deadline = Clock::now() + 30s;
  while ((metric(d.port, "skinspec_compute_running") < 2 || metric(d.port, "skinspec_compute_waiting") < 2) &&
         Clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  ASSERT_EQ(metric(d.port, "skinspec_compute_waiting"), 2) << "the compute pool never filled";

  std::vector<double> ms;
  for (int i = 0; i < 9; ++i) {
    const auto asked = Clock::now();
    EXPECT_EQ(http_request(d.port, "GET", "/healthz").status, 200);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - asked).count());
  }
  const auto over = http_request(d.port, "POST", "/api/v1/fit", body);
  // Still saturated: the probes ran beside the fits, not after them.
  EXPECT_EQ(metric(d.port, "skinspec_compute_running"), 2);
  std::sort(ms.begin(), ms.end());
  EXPECT_LT(ms[ms.size() / 2], 100) << "median /healthz latency with the compute pool full";
  EXPECT_LT(ms.back(), 1000) << "slowest /healthz";
  expect_json_error(over, 503, "compute_busy");
  EXPECT_EQ(over.header("retry-after"), "1");
  for (auto& f : fits) {
    const auto r = f.get();
    EXPECT_EQ(r.status, 200) << r.error;
    EXPECT_EQ(r.json()["fits"].size(), 100u);
  }
  std::cout << "healthz ms with the compute pool full: median " << ms[ms.size() / 2] << ", max " << ms.back() << '\n';
}

// Raises this process's soft limit on open files to the hard limit (the daemon, its child,
// inherits it); false when even that is below `needed`.
bool raise_open_files_limit(rlim_t needed, rlim_t& hard) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0) return false;
  hard = limit.rlim_max;
  limit.rlim_cur = limit.rlim_max;
  return ::setrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_max >= needed;
}

TEST_F(HttpProcessTest, OneClientsThousandIdleConnectionsDoNotLockOutAnother) {
  rlim_t hard = 0;
  ASSERT_TRUE(raise_open_files_limit(1200, hard))
      << "this test holds 1000 connections and needs a limit on open files of at least 1200; the hard limit is " << hard
      << " (raise it with ulimit -Hn or in limits.conf)";
  auto d = start({});
  ASSERT_NE(d.port, 0);
  IdleClients flood;
  flood.open(d.port, 1000);
  for (const std::string source : {"127.0.0.1", "127.0.0.2"}) {
    const auto asked = Clock::now();
    const std::string answer = healthz_from(source, d.port);
    EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u) << source << ": " << answer;
    EXPECT_LT(Clock::now() - asked, 5s) << source;
  }
  // The flood holds no more than its share (64 by default), the rest were closed.
  EXPECT_LE(metric(d.port, "skinspec_open_connections"), 64 + 1);
  EXPECT_GE(metric(d.port, "skinspec_evicted_connections_total"), 1000 - 64);
  EXPECT_TRUE(flood.closed_by_server(0, 5s));
}

TEST_F(HttpProcessTest, AtTheCapTheLongestIdleConnectionGivesWayAndBusyOnesAreKept) {
  auto d = start({"--max-connections", "3", "--max-connections-per-client", "3"});
  ASSERT_NE(d.port, 0);
  IdleClients mine;
  mine.open(d.port, 3);
  std::this_thread::sleep_for(200ms);  // accepted, in order
  // A newcomer from another address takes the place of the first, idle longest.
  EXPECT_EQ(healthz_from("127.0.0.2", d.port).rfind("HTTP/1.1 200", 0), 0u);
  EXPECT_TRUE(mine.closed_by_server(0, 5s));
  EXPECT_FALSE(mine.closed_by_server(1, 100ms));
  EXPECT_FALSE(mine.closed_by_server(2, 100ms));
  // Connections with a request on its way are never displaced: then the newcomer gets a 503.
  IdleClients more;
  more.open(d.port, 1, "127.0.0.3");
  for (std::size_t i : {1u, 2u}) asio::write(mine.at(i), asio::buffer(std::string("GET /healthz HTTP/1.1\r\n")));
  asio::write(more.at(0), asio::buffer(std::string("GET /healthz HTTP/1.1\r\n")));
  std::this_thread::sleep_for(200ms);
  const auto refused = parse_responses(healthz_from("127.0.0.4", d.port));
  ASSERT_EQ(refused.size(), 1u);
  expect_json_error(refused[0], 503, "too_many_connections");
  for (std::size_t i : {1u, 2u}) asio::write(mine.at(i), asio::buffer(std::string("Host: x\r\n\r\n")));
  EXPECT_FALSE(mine.closed_by_server(1, 100ms));
}

TEST_F(HttpProcessTest, OneAddressOverItsShareDisplacesOnlyItsOwnIdleConnection) {
  auto d = start({"--max-connections-per-client", "2"});
  ASSERT_NE(d.port, 0);
  IdleClients mine, theirs;
  mine.open(d.port, 2);
  theirs.open(d.port, 2, "127.0.0.2");
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(healthz_from("127.0.0.1", d.port).rfind("HTTP/1.1 200", 0), 0u);
  EXPECT_TRUE(mine.closed_by_server(0, 5s));
  EXPECT_FALSE(mine.closed_by_server(1, 100ms));
  EXPECT_FALSE(theirs.closed_by_server(0, 100ms));
  EXPECT_FALSE(theirs.closed_by_server(1, 100ms));
}

}  // namespace
}  // namespace skinspec::testing
