#pragma once
// Accepts connections and hands each to the server, without ever spinning: when the process
// runs out of file descriptors (EMFILE, ENFILE) a pending connection is accepted on the spare
// descriptor, answered 503 and closed, and when even that fails accepting pauses briefly.

#include <chrono>
#include <expected>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "descriptors.hpp"
#include "skinspec/api/errors.hpp"

namespace skinspec::api::detail {

// The bytes of the answer to `error` outside any request: HTTP/1.1, then close.
std::string refusal_bytes(const ApiError& error);
// Writes `reply` without waiting (it fits any socket buffer), then closes.
void refuse_connection(boost::asio::ip::tcp::socket& socket, std::string_view reply);

class Listener : public std::enable_shared_from_this<Listener> {
 public:
  // An accepted connection, and the index in `contexts` of the one it is on.
  using Admit = std::function<void(boost::asio::ip::tcp::socket, std::size_t)>;
  // `admit` gets each accepted connection, on each of `contexts` in turn (the first is the
  // listener's own); `shed` is told of each one refused for want of descriptors.
  Listener(std::vector<boost::asio::io_context*> contexts, Admit admit, std::function<void()> shed);

  std::expected<void, std::string> open(const boost::asio::ip::tcp::endpoint& endpoint);
  unsigned short port() const;
  // Accepts until close().
  void start();
  // Thread-safe.
  void close();

  // How long accepting pauses when no descriptor could be found for a pending connection.
  static constexpr std::chrono::milliseconds kPause{100};

 private:
  void accept();
  void on_error(const boost::system::error_code& ec);
  // Accepts one pending connection on the spare descriptor and refuses it; false when none could be.
  bool shed_one();
  void pause();

  std::vector<boost::asio::io_context*> contexts_;
  std::size_t next_ = 0;          // on the strand
  boost::asio::io_context& ioc_;  // the listener's own, the first
  boost::asio::strand<boost::asio::io_context::executor_type> strand_;
  boost::asio::ip::tcp::acceptor acceptor_;
  boost::asio::steady_timer pause_;
  Admit admit_;
  std::function<void()> shed_;
  SpareDescriptor spare_;
  // Made beforehand: shedding happens when the process has no descriptors to spare, and
  // should need nothing new.
  const std::string shed_reply_;
  bool closed_ = false;  // on the strand
};

}  // namespace skinspec::api::detail
