// From a parsed URI to the transport that serves it. A usb: URI names an adapter, not a
// tty, because the kernel numbers ttys in plug-in order; the tty is looked up here, at the
// moment the transport is made.

#include "skinspec/drivers/discovery.hpp"
#include "skinspec/drivers/transport.hpp"
#include "transport/transports.hpp"

namespace skinspec::drivers {

std::expected<std::unique_ptr<Transport>, std::string> make_transport(const ConnectionUri& uri) {
  switch (uri.scheme) {
    case ConnectionUri::Scheme::serial:
      return detail::make_serial_transport(uri.path, uri, uri.to_string());
    case ConnectionUri::Scheme::tcp:
      return detail::make_tcp_transport(uri);
    case ConnectionUri::Scheme::usb: {
      auto path = find_usb_port(uri.vendor_id, uri.product_id, uri.usb_serial);
      if (!path) return std::unexpected(path.error());
      return detail::make_serial_transport(*path, uri, uri.to_string() + " (" + *path + ")");
    }
  }
  return std::unexpected("unsupported connection URI scheme");
}

}  // namespace skinspec::drivers
