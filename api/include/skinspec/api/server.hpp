#pragma once
// The Beast HTTP server in front of a Router: a listener that accepts connections, and one
// session per connection that reads requests with limits and timeouts, hands them to the
// router, and writes the responses back, keeping the connection alive when the client asks for
// it. The router runs on a pool of workers, and the heavy routes (fits, renders) on a bounded
// pool of their own, so that they never hold up the others. A response with an event source is
// streamed in chunks, pulled on a thread per stream, until the source ends, the client hangs
// up or the server stops. Connections are shared out fairly (docs/api.md, "Connections"): each
// client address may hold a number of them, and a newcomer over a limit takes the place of the
// connection idle longest. With a TLS context every connection is HTTPS (tls.hpp).

#include <chrono>
#include <cstddef>
#include <expected>
#include <memory>
#include <vector>
#include <string>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>

#include "skinspec/api/router.hpp"
#include "skinspec/api/tls.hpp"

namespace skinspec::api {

struct ServerOptions {
  std::string address = "127.0.0.1";
  unsigned short port = 8650;  // 0: any free port (see Server::port())
  std::size_t body_limit = 1024 * 1024;
  std::size_t header_limit = 8 * 1024;
  // A request (its headers and body) must arrive within this from its first byte, or from the
  // end of the previous response on a kept-alive connection; otherwise the connection is closed.
  std::chrono::milliseconds read_timeout{10000};
  std::chrono::milliseconds write_timeout{30000};
  // A file sent to a route that takes one (Router::is_upload: an import) may be this large and
  // take this long to arrive.
  std::size_t upload_limit = 512 * 1024 * 1024;
  std::chrono::milliseconds upload_timeout{300000};
  // A streamed body (Server-Sent Events) sends a keep-alive comment after this much silence.
  std::chrono::milliseconds event_keep_alive{15000};
  // Connections held at once, at most what the file-descriptor limit leaves room for; and per
  // client address. A newcomer over either takes the place of the longest-idle connection, or
  // gets a 503 when none is idle.
  std::size_t max_connections = 512;
  std::size_t max_connections_per_client = 64;
  // Threads reading requests and writing answers, each with the connections it is given: one
  // serves tens of thousands of requests a second (docs/api.md, `--io-threads`).
  int io_threads = 1;
  int worker_threads = 2;  // where the router runs the light routes
  // The heavy routes (fits, renders): threads, and requests that may wait for one; beyond them
  // a 503 with Retry-After.
  std::size_t compute_threads = 2;
  std::size_t compute_queue = 8;
  // Set (make_tls_context): every connection is HTTPS, its handshake held to read_timeout like
  // a request, with the context current when it was accepted. Null: plain HTTP.
  std::shared_ptr<TlsCredentials> tls;
};

// The connection limits in force, after listen().
struct ServerLimits {
  std::size_t max_connections = 0;  // less than asked when the descriptor limit is too low
  std::size_t max_connections_per_client = 0;
  std::size_t descriptor_limit = 0;  // RLIMIT_NOFILE
};

class Server {
 public:
  Server(const Router& router, ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and listens; an explanation when the address cannot be used.
  std::expected<void, std::string> listen();
  // The bound port (useful with port 0), after listen().
  unsigned short port() const;
  ServerLimits limits() const;

  // Serves on io_threads threads (this one included), each with an I/O context of its own that
  // its connections stay on, until stop() and the end of every connection's in-flight request.
  // (One context run by every thread made its connections' handlers move from thread to thread,
  // and serving a cached answer took half as long again or twice as long, by turns.)
  void run();
  // Stops accepting, closes idle connections and lets requests in flight finish. Thread-safe.
  void stop();

  // The first thread's context, where the server listens.
  boost::asio::io_context& context() { return ioc_; }

  struct State;

 private:
  using WorkGuard = boost::asio::executor_work_guard<boost::asio::io_context::executor_type>;

  boost::asio::io_context ioc_;
  // The other threads' contexts, kept running while the server listens.
  std::vector<std::unique_ptr<boost::asio::io_context>> more_contexts_;
  std::vector<WorkGuard> keep_running_;
  std::shared_ptr<State> state_;
};

}  // namespace skinspec::api
