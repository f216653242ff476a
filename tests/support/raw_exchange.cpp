#include "support/raw_exchange.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/tcp_stream.hpp>

namespace skinspec::testing {

namespace asio = boost::asio;
namespace beast = boost::beast;
using tcp = asio::ip::tcp;

std::string raw_exchange(unsigned short port, const std::string& bytes, std::chrono::milliseconds timeout) {
  return raw_exchange_from("127.0.0.1", port, bytes, timeout).bytes;
}

RawExchange raw_exchange_from(const std::string& source, unsigned short port, const std::string& bytes,
                              std::chrono::milliseconds timeout) {
  RawExchange out;
  asio::io_context ioc;
  beast::tcp_stream stream(ioc);
  beast::error_code ec;
  stream.socket().open(tcp::v4(), ec);
  stream.socket().bind(tcp::endpoint(asio::ip::make_address(source), 0), ec);
  if (ec) return out;
  stream.expires_after(timeout);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port), ec);
  if (ec) return out;
  stream.expires_after(timeout);
  asio::write(stream, asio::buffer(bytes), ec);
  char chunk[4096];
  for (;;) {
    const std::size_t n = stream.read_some(asio::buffer(chunk), ec);
    out.bytes.append(chunk, n);
    if (ec) break;
  }
  out.closed = ec == asio::error::eof || ec == asio::error::connection_reset;
  return out;
}

}  // namespace skinspec::testing
