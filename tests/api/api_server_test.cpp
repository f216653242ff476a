// The server's parts in-process: who gives way when connections run short, the bound on heavy
// work, the cap the descriptor limit allows, and one HTTP exchange's framing rules and HEAD.

#include <gtest/gtest.h>

#include <future>

#include "compute_pool.hpp"
#include "connection_table.hpp"
#include "descriptors.hpp"
#include "http_exchange.hpp"
#include "skinspec/api/router.hpp"

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
  for (const char* accepted :
       {"", "Transfer-Encoding: chunked\r\n", "Transfer-Encoding: Chunked\r\n", "Content-Length: 3\r\n"})
    EXPECT_FALSE(detail::check_framing(parsed(std::string("POST / HTTP/1.1\r\n") + accepted + "\r\n"))) << accepted;
  for (const char* refused :
       {"Transfer-Encoding: gzip\r\n", "Transfer-Encoding: identity\r\n", "Transfer-Encoding: chunked, identity\r\n",
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

}  // namespace
}  // namespace skinspec::api
