// The server's I/O threads, each with a context of its own: connections are given to each in
// turn (as /metrics counts them) and all served, and a stop ends every thread's work, idle
// connections and all, so that run() returns.

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "skinspec/api/router.hpp"
#include "skinspec/api/server.hpp"
#include "skinspec/client/http_client.hpp"

namespace skinspec::api {
namespace {

using namespace std::chrono_literals;

TEST(ServerThreads, ConnectionsOnEveryThreadAreServedAndAStopEndsThemAll) {
  const Router router(RouterContext{});
  ServerOptions options;
  options.port = 0;
  options.io_threads = 3;
  options.worker_threads = 1;
  Server server(router, options);
  ASSERT_TRUE(server.listen());
  // Every I/O thread is counted from the start, a thread without connections at 0.
  EXPECT_NE(router.metrics().prometheus_text().find("skinspec_accepted_connections_total{io_thread=\"2\"} 0\n"),
            std::string::npos);
  auto running = std::async(std::launch::async, [&] { server.run(); });

  // Seven connections over three threads: each thread holds two or three, kept open and idle.
  std::vector<std::unique_ptr<client::HttpConnection>> kept;
  for (int i = 0; i < 7; ++i) {
    kept.push_back(std::make_unique<client::HttpConnection>(server.port()));
    EXPECT_EQ(kept.back()->request("GET", "/healthz").status, 200) << "connection " << i;
  }
  for (auto& connection : kept) EXPECT_EQ(connection->request("GET", "/healthz").status, 200);
  // In turn: the seven and this eighth, which asks, are three, three and two.
  const auto metrics = client::http_request(server.port(), "GET", "/metrics");
  EXPECT_EQ(metrics.status, 200);
  for (const char* line : {"skinspec_accepted_connections_total{io_thread=\"0\"} 3\n",
                           "skinspec_accepted_connections_total{io_thread=\"1\"} 3\n",
                           "skinspec_accepted_connections_total{io_thread=\"2\"} 2\n"})
    EXPECT_NE(metrics.body.find(line), std::string::npos) << line << " not in\n" << metrics.body;

  const auto port = server.port();
  server.stop();
  if (running.wait_for(10s) != std::future_status::ready) {
    ADD_FAILURE() << "run() still serving 10 s after stop()";
    std::_Exit(1);  // the server's threads would hold the test up for good
  }
  running.get();
  // Closed once stopped, kept ones and new ones alike.
  for (auto& connection : kept) EXPECT_NE(connection->request("GET", "/healthz").status, 200);
  EXPECT_FALSE(client::http_request(port, "GET", "/healthz").error.empty());
}

}  // namespace
}  // namespace skinspec::api
