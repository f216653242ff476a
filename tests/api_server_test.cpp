// The server's parts in-process: who gives way when connections run short, the bound on heavy
// work, the cap the descriptor limit allows, and the real server when the process has run
// out of file descriptors.

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/resource.h>
#include <unistd.h>

#include <future>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

#include "compute_pool.hpp"
#include "connection_table.hpp"
#include "descriptors.hpp"
#include "http_exchange.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/api/server.hpp"
#include "support/http_client.hpp"

namespace skinspec::api {
namespace {

using detail::ConnectionTable;
using Refusal = ConnectionTable::Refusal;
using namespace std::chrono_literals;

TEST(ConnectionTable, AClientOverItsShareDisplacesItsOwnLongestIdleConnection) {
  ConnectionTable table({.total = 10, .per_client = 2});
  EXPECT_EQ(table.admit(1, "a").refusal, Refusal::none);
  EXPECT_EQ(table.admit(2, "b").refusal, Refusal::none);
  EXPECT_EQ(table.admit(3, "a").refusal, Refusal::none);
  const auto third = table.admit(4, "a");
  EXPECT_EQ(third.refusal, Refusal::none);
  EXPECT_EQ(third.evicted, 1u);
  EXPECT_EQ(table.count("a"), 2u);
  EXPECT_EQ(table.count("b"), 1u);
  EXPECT_FALSE(table.set_busy(1)) << "an evicted connection must close";
  // Busy connections are never displaced.
  EXPECT_TRUE(table.set_busy(3));
  EXPECT_TRUE(table.set_busy(4));
  const auto refused = table.admit(5, "a");
  EXPECT_EQ(refused.refusal, Refusal::client_full);
  EXPECT_FALSE(refused.evicted);
  EXPECT_EQ(table.size(), 3u);
}

TEST(ConnectionTable, AtTheCapTheConnectionIdleLongestGivesWay) {
  ConnectionTable table({.total = 3, .per_client = 3});
  table.admit(1, "a");
  table.admit(2, "b");
  table.admit(3, "c");
  // 1 serves a request and waits again: now 2 has been idle longest.
  EXPECT_TRUE(table.set_busy(1));
  table.set_idle(1);
  EXPECT_EQ(table.admit(4, "d").evicted, 2u);
  EXPECT_EQ(table.admit(5, "d").evicted, 3u);
  EXPECT_EQ(table.admit(6, "d").evicted, 1u);
  for (ConnectionTable::Id id : {4u, 5u, 6u}) EXPECT_TRUE(table.set_busy(id));
  EXPECT_EQ(table.admit(7, "e").refusal, Refusal::server_full);
  table.remove(5);
  EXPECT_EQ(table.admit(7, "e").refusal, Refusal::none);
  EXPECT_EQ(table.size(), 3u);
  EXPECT_EQ(table.count("d"), 2u);
}

TEST(ConnectionTable, LimitsAreAtLeastOneAndThePerClientShareAtMostTheTotal) {
  const ConnectionTable table({.total = 0, .per_client = 100});
  EXPECT_EQ(table.limits().total, 1u);
  EXPECT_EQ(table.limits().per_client, 1u);
}

TEST(Descriptors, TheConnectionCapLeavesRoomForTheDescriptorsInUseAndAReserve) {
  EXPECT_EQ(detail::connection_cap(512, 20000, 20, 64), 512u);
  EXPECT_EQ(detail::connection_cap(512, 200, 20, 64), 116u);
  EXPECT_EQ(detail::connection_cap(512, 50, 20, 64), 1u);
  EXPECT_EQ(detail::connection_cap(512, SIZE_MAX, 20, 64), 512u);
  EXPECT_GT(detail::open_descriptors(), 2u);  // at least standard input, output and error
}

TEST(ComputePool, RunsSoManyAtOnceQueuesSoManyAndRefusesTheRest) {
  std::vector<std::pair<std::size_t, std::size_t>> loads;
  std::mutex loads_mutex;
  detail::ComputePool pool(1, 1, [&](std::size_t running, std::size_t waiting) {
    std::lock_guard lock(loads_mutex);
    loads.emplace_back(running, waiting);
  });
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> first_started;
  std::atomic<int> done{0};
  EXPECT_TRUE(pool.try_post([&] {
    first_started.set_value();
    released.wait();
    ++done;
  }));
  first_started.get_future().wait();
  EXPECT_TRUE(pool.try_post([&] { ++done; }));
  EXPECT_EQ(pool.running(), 1u);
  EXPECT_EQ(pool.waiting(), 1u);
  EXPECT_FALSE(pool.try_post([&] { done += 100; }));
  release.set_value();
  pool.join();
  EXPECT_EQ(done, 2);
  EXPECT_EQ(pool.running(), 0u);
  std::lock_guard lock(loads_mutex);
  ASSERT_FALSE(loads.empty());
  EXPECT_EQ(loads.back(), std::make_pair(std::size_t{0}, std::size_t{0}));
}


// The header of `head` (a request up to its blank line) as the server's parser reads it.
detail::RequestMessage parsed(const std::string& head) {
  detail::RequestParser parser;
  detail::prepare_parser(parser, {});
  boost::beast::error_code ec;
  parser.put(boost::asio::buffer(head), ec);
  EXPECT_TRUE(parser.is_header_done()) << head << ec.message();
  return parser.release();
}

TEST(HttpExchange, OnlyChunkedAloneIsAcceptedAsTransferEncoding) {
  for (const char* accepted : {"", "Transfer-Encoding: chunked\r\n", "Transfer-Encoding: Chunked\r\n", "Content-Length: 3\r\n"})
    EXPECT_FALSE(detail::check_framing(parsed(std::string("POST / HTTP/1.1\r\n") + accepted + "\r\n"))) << accepted;
  for (const char* refused : {"Transfer-Encoding: gzip\r\n", "Transfer-Encoding: identity\r\n", "Transfer-Encoding: chunked, identity\r\n",
                              "Transfer-Encoding: gzip, chunked\r\n", "Transfer-Encoding: gzip\r\nTransfer-Encoding: chunked\r\n",
                              "Transfer-Encoding: gzip\r\nContent-Length: 3\r\n"}) {
    const auto error = detail::check_framing(parsed(std::string("POST / HTTP/1.1\r\n") + refused + "\r\n"));
    ASSERT_TRUE(error) << refused;
    EXPECT_EQ(error->kind, ErrorKind::bad_request);
    EXPECT_EQ(error->code, "invalid_framing");
  }
  EXPECT_TRUE(detail::check_framing(parsed("POST / HTTP/1.0\r\nTransfer-Encoding: chunked\r\n\r\n")));
}

TEST(HttpExchange, AHeadIsRoutedAsGetAndAnsweredWithTheHeadersOfItsAnswer) {
  const auto head = parsed("HEAD /healthz?x=1 HTTP/1.1\r\nHost: a\r\nX-Thing: B\r\n\r\n");
  const Request request = detail::to_request(head);
  EXPECT_EQ(request.method, "GET");
  EXPECT_EQ(request.target, "/healthz?x=1");
  EXPECT_EQ(request.headers.at("x-thing"), "B");
  const Response response{200, "application/json", "{\"status\":\"ok\"}", {{"X-Render-Cache", "hit"}}};
  const auto reply = detail::to_reply(response, head, true);
  EXPECT_TRUE(reply.body().empty());
  EXPECT_EQ(reply[boost::beast::http::field::content_length], std::to_string(response.body.size()));
  EXPECT_EQ(reply["X-Render-Cache"], "hit");
  const auto get = detail::to_reply(response, parsed("GET /healthz HTTP/1.1\r\n\r\n"), true);
  EXPECT_EQ(get.body(), response.body);
  EXPECT_EQ(get[boost::beast::http::field::content_length], reply[boost::beast::http::field::content_length]);
}

// What arrives on `fd` until the peer closes it or `timeout` passes.
std::string read_until_closed(int fd, std::chrono::milliseconds timeout) {
  std::string out;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd ready{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&ready, 1, static_cast<int>(left.count())) <= 0) return out;
    char chunk[1024];
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n <= 0) return out;
    out.append(chunk, static_cast<std::size_t>(n));
  }
}

std::chrono::milliseconds process_cpu_time() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  const auto ms = [](const timeval& t) { return std::chrono::milliseconds(t.tv_sec * 1000 + t.tv_usec / 1000); };
  return ms(usage.ru_utime) + ms(usage.ru_stime);
}

// Takes every descriptor the process has left (under a soft limit lowered for the purpose)
// until released.
class DescriptorHog {
 public:
  DescriptorHog() {
    ::getrlimit(RLIMIT_NOFILE, &saved_);
    rlimit lower = saved_;
    lower.rlim_cur = static_cast<rlim_t>(detail::open_descriptors() + 32);
    ::setrlimit(RLIMIT_NOFILE, &lower);
    for (int fd; (fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC)) >= 0;) held_.push_back(fd);
  }
  ~DescriptorHog() { release(); }
  void release() {
    for (int fd : held_) ::close(fd);
    held_.clear();
    ::setrlimit(RLIMIT_NOFILE, &saved_);
  }
  std::size_t held() const { return held_.size(); }

 private:
  rlimit saved_{};
  std::vector<int> held_;
};

TEST(ServerOutOfDescriptors, RefusesNewcomersWith503KeepsServingAndDoesNotSpin) {
  const Router router(RouterContext{});
  ServerOptions options;
  options.port = 0;
  options.io_threads = 1;
  options.worker_threads = 1;
  Server server(router, options);
  ASSERT_TRUE(server.listen());
  std::thread running([&] { server.run(); });
  const auto port = server.port();

  testing::HttpConnection kept(port);
  ASSERT_EQ(kept.request("GET", "/healthz").status, 200);
  // The newcomers' sockets exist before the descriptors run out; connecting needs no more.
  boost::asio::io_context ioc;
  std::vector<boost::asio::ip::tcp::socket> late;
  for (int i = 0; i < 3; ++i) late.emplace_back(ioc).open(boost::asio::ip::tcp::v4());

  std::vector<std::string> answers;
  std::chrono::milliseconds cpu{0};
  int kept_status = 0;
  {
    DescriptorHog hog;
    ASSERT_GT(hog.held(), 0u);
    for (auto& s : late) {
      s.connect({boost::asio::ip::make_address("127.0.0.1"), port});
      answers.push_back(read_until_closed(s.native_handle(), 5s));
    }
    const auto before = process_cpu_time();
    std::this_thread::sleep_for(1s);
    cpu = process_cpu_time() - before;
    kept_status = kept.request("GET", "/healthz").status;
  }
  for (const auto& answer : answers) {
    EXPECT_EQ(answer.rfind("HTTP/1.1 503", 0), 0u) << answer;
    EXPECT_NE(answer.find("\"too_many_connections\""), std::string::npos) << answer;
  }
  EXPECT_LT(cpu, 200ms) << "CPU used in 1 s while out of descriptors";
  EXPECT_EQ(kept_status, 200);
  // Descriptors back: new connections are served again.
  EXPECT_EQ(testing::http_request(port, "GET", "/healthz").status, 200);
  EXPECT_NE(router.metrics().prometheus_text().find("skinspec_rejected_connections_total 3"), std::string::npos);
  server.stop();
  running.join();
}

}  // namespace
}  // namespace skinspec::api
