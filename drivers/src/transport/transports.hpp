#pragma once
// The concrete transports behind make_transport(). Each lives in its own file so that only
// serial_transport.cpp sees libserialport and only tcp_transport.cpp sees Boost.Asio.

#include <chrono>
#include <memory>
#include <string>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers::detail {

// A serial port at `path` with the URI's line settings; `label` is what describe() says
// (the URI the user gave, which for usb: is not the path).
std::unique_ptr<Transport> make_serial_transport(std::string path, const ConnectionUri& settings, std::string label);

// A raw TCP connection to a serial server (ser2net, a terminal server) or to a simulator.
std::unique_ptr<Transport> make_tcp_transport(const ConnectionUri& uri,
                                              std::chrono::milliseconds connect_timeout = std::chrono::seconds(5));

}  // namespace skinspec::drivers::detail
