// The real server in-process when the process has run out of file descriptors: newcomers are
// refused with a 503 on the spare descriptor, open connections are still served, nothing spins,
// and service resumes once descriptors are free again.

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

#include "descriptors.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/api/server.hpp"
#include "skinspec/client/http_client.hpp"

namespace skinspec::api {
namespace {

using namespace std::chrono_literals;

// What arrives on `fd` until the peer closes it or `timeout` passes.
std::string read_until_closed(int fd, std::chrono::milliseconds timeout) {
  std::string out;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
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

  client::HttpConnection kept(port);
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
  EXPECT_EQ(client::http_request(port, "GET", "/healthz").status, 200);
  EXPECT_NE(router.metrics().prometheus_text().find("skinspec_rejected_connections_total 3"), std::string::npos);
  server.stop();
  running.join();
}

}  // namespace
}  // namespace skinspec::api
