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
  std::optional<UsbIdentity> adapter;  // the USB adapter or meter behind it, when there is one
};

using DeviceResolver = std::function<std::expected<ResolvedDevice, std::string>(const std::string& device)>;

// The resolver of the real system: serial: and tcp: as they are; usb:VID:PID[:SERIAL] the tty
// of that USB device today; `auto` the port auto_device() chooses, an error saying that no USB
// serial device was found when there is none.
std::expected<ResolvedDevice, std::string> resolve_device(const std::string& device);

// What `auto` connects to among `ports` (only those with a USB vendor and product id count):
//   1. a Photo Research meter (180b:0524, the newer meters' own USB port);
//   2. a Photo Research device of another product id;
//   3. an RS-232 adapter of the known-devices table (a PR-650's cable);
//   4. any other USB serial device;
// within each, the first in path order. None when no port is a USB device.
std::optional<drivers::PortInfo> auto_device(std::vector<drivers::PortInfo> ports);

// Whether --device names a USB device, adapter or meter (usb: or auto), so that hot-plug matters.
bool follows_usb_adapters(const std::string& device);

// Whether a hot-plug event concerns `adapter` (an event without a serial number matches by
// vendor and product alone).
bool concerns(const drivers::UsbDeviceEvent& event, const UsbIdentity& adapter);

// GET /api/v1/ports: {"ports": [{uri, name, description, transport, usb: {vid, pid, serial,
// manufacturer, product, device_kind, device_description} | null}]}, the uri being what
// --device would take (usb:VID:PID[:SERIAL] for a USB device, as it survives re-plugging) and
// device_kind "photo-research-meter", "rs232-adapter" or null for a device not in the table.
nlohmann::json ports_json(const std::vector<drivers::PortInfo>& ports);

}  // namespace skinspec::daemon
