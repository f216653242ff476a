#pragma once
// From what --device says to the port the supervisor opens, looked up afresh on every
// connection attempt: a usb: adapter or `auto` may come back under another tty name after it
// was unplugged. The lookup is a function the supervisor is given, so that tests can stand a
// simulator in for a USB adapter.

#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/drivers/discovery.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::daemon {

struct UsbIdentity {
  unsigned short vendor_id = 0, product_id = 0;
  std::string serial_number;  // empty: any adapter of this vendor and product
};

struct ResolvedDevice {
  drivers::ConnectionUri uri;          // serial: or tcp:, never usb:
  std::optional<UsbIdentity> adapter;  // the USB adapter behind it, when there is one
};

using DeviceResolver = std::function<std::expected<ResolvedDevice, std::string>(const std::string& device)>;

// The resolver of the real system: serial: and tcp: as they are; usb:VID:PID[:SERIAL] the tty
// of that adapter today; `auto` the first USB serial adapter in path order (the first port
// that has a USB vendor and product id), "no USB serial adapter found" when there is none.
std::expected<ResolvedDevice, std::string> resolve_device(const std::string& device);

// The first USB serial adapter of `ports` in path order, if any.
std::optional<drivers::PortInfo> first_usb_adapter(std::vector<drivers::PortInfo> ports);

// Whether --device names a USB adapter (usb: or auto), so that hot-plug matters.
bool follows_usb_adapters(const std::string& device);

// Whether a hot-plug event concerns `adapter` (an event without a serial number matches by
// vendor and product alone).
bool concerns(const drivers::UsbDeviceEvent& event, const UsbIdentity& adapter);

// GET /api/v1/ports: {"ports": [{uri, name, description, transport, usb: {...} | null}]}, the
// uri being what --device would take (usb:VID:PID[:SERIAL] for an adapter, as it survives
// re-plugging).
nlohmann::json ports_json(const std::vector<drivers::PortInfo>& ports);

}  // namespace skinspec::daemon
