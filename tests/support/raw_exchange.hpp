#pragma once
// Test helper: bytes written to skinspecd on loopback as they are, for requests a well-behaved
// client (skinspec/client/http_client.hpp, which parses what comes back) would never send.

#include <chrono>
#include <string>

namespace skinspec::testing {

// Writes `bytes` as they are and reads until the server closes the connection or `timeout`
// passes; everything the server sent.
std::string raw_exchange(unsigned short port, const std::string& bytes, std::chrono::milliseconds timeout);

// What a raw exchange got back, and whether the server closed the connection (rather than the
// timeout passing first).
struct RawExchange {
  std::string bytes;
  bool closed = false;
};
// As raw_exchange, connecting from `source`: any address of 127/8 (another client to the server).
RawExchange raw_exchange_from(const std::string& source, unsigned short port, const std::string& bytes,
                              std::chrono::milliseconds timeout);

}  // namespace skinspec::testing
