// Which serial ports the system has and which USB adapter is behind each. libserialport
// reads this from the OS (sysfs on Linux); where it could not get a device's strings, libusb
// reads them from the device itself, if the user may open it.

#include "skinspec/drivers/discovery.hpp"

#include <libserialport.h>
#include <fmt/format.h>

#include <algorithm>

#include "discovery/usb_devices.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

namespace {

// Where a USB port's device sits, to find it again through libusb.
struct UsbLocation {
  int bus = -1, address = -1;
};

std::string text(const char* maybe_null) { return maybe_null ? maybe_null : ""; }

std::string kind_name(sp_transport transport) {
  switch (transport) {
    case SP_TRANSPORT_NATIVE:
      return "native";
    case SP_TRANSPORT_USB:
      return "usb";
    case SP_TRANSPORT_BLUETOOTH:
      return "bluetooth";
  }
  return "unknown";
}

PortInfo describe_port(const sp_port* port, UsbLocation& location) {
  PortInfo info;
  info.path = text(sp_get_port_name(port));
  info.description = text(sp_get_port_description(port));
  const sp_transport transport = sp_get_port_transport(port);
  info.kind = kind_name(transport);
  if (transport != SP_TRANSPORT_USB) return info;
  int vid = 0, pid = 0;
  if (sp_get_port_usb_vid_pid(port, &vid, &pid) == SP_OK) {
    info.vendor_id = static_cast<unsigned short>(vid);
    info.product_id = static_cast<unsigned short>(pid);
  }
  info.serial_number = text(sp_get_port_usb_serial(port));
  info.manufacturer = text(sp_get_port_usb_manufacturer(port));
  info.product = text(sp_get_port_usb_product(port));
  if (sp_get_port_usb_bus_address(port, &location.bus, &location.address) != SP_OK) location = {};
  return info;
}

bool lacks_strings(const PortInfo& port) {
  return port.kind == "usb" && (port.serial_number.empty() || port.manufacturer.empty() || port.product.empty());
}

void fill_missing(std::string& field, const std::string& value) {
  if (field.empty()) field = value;
}

// Starting libusb costs a scan of the bus, so it is done only when some string is missing.
void fill_strings_from_libusb(std::vector<PortInfo>& ports, const std::vector<UsbLocation>& locations) {
  if (std::none_of(ports.begin(), ports.end(), lacks_strings)) return;
  const detail::UsbContext context;
  if (!context.get()) return;
  for (std::size_t i = 0; i < ports.size(); ++i) {
    if (!lacks_strings(ports[i]) || locations[i].bus < 0) continue;
    const auto strings = detail::usb_strings_at(context, locations[i].bus, locations[i].address);
    if (!strings) continue;
    fill_missing(ports[i].serial_number, strings->serial_number);
    fill_missing(ports[i].manufacturer, strings->manufacturer);
    fill_missing(ports[i].product, strings->product);
  }
}

std::string usb_id(unsigned short vendor_id, unsigned short product_id) {
  return fmt::format("{:04x}:{:04x}", vendor_id, product_id);
}

// "180b:0524 serial '60912345' (Photo Research meter) on /dev/ttyACM0"
std::string device_name(const PortInfo& port) {
  std::string name = usb_id(port.vendor_id.value_or(0), port.product_id.value_or(0));
  if (!port.serial_number.empty()) name += fmt::format(" serial '{}'", port.serial_number);
  if (const auto known = classify_port(port)) name += fmt::format(" ({})", known->description);
  return fmt::format("{} on {}", name, port.path);
}

std::string device_list(const std::vector<PortInfo>& devices) {
  std::vector<std::string> names;
  for (const auto& device : devices) names.push_back(device_name(device));
  return fmt::format("{}", fmt::join(names, ", "));
}

}  // namespace

std::vector<PortInfo> list_ports() {
  sp_port** list = nullptr;
  if (sp_list_ports(&list) != SP_OK) return {};
  std::vector<PortInfo> ports;
  std::vector<UsbLocation> locations;
  for (sp_port** port = list; *port; ++port) {
    locations.emplace_back();
    ports.push_back(describe_port(*port, locations.back()));
  }
  sp_free_port_list(list);
  fill_strings_from_libusb(ports, locations);
  std::sort(ports.begin(), ports.end(), [](const PortInfo& a, const PortInfo& b) { return a.path < b.path; });
  return ports;
}

std::string stable_uri(const PortInfo& port) {
  ConnectionUri uri;
  if (port.vendor_id && port.product_id) {
    uri.scheme = ConnectionUri::Scheme::usb;
    uri.vendor_id = *port.vendor_id;
    uri.product_id = *port.product_id;
    uri.usb_serial = port.serial_number;
  } else {
    uri.path = port.path;
  }
  return uri.to_string();
}

// Without a serial number two identical devices cannot be told apart; guessing could talk
// to the wrong instrument, so that is an error too.
std::expected<std::string, std::string> find_usb_port(unsigned short vendor_id, unsigned short product_id,
                                                      const std::string& serial_number) {
  std::vector<PortInfo> present, matches;
  for (auto& port : list_ports()) {
    if (port.kind != "usb" || !port.vendor_id) continue;
    const bool same = port.vendor_id == vendor_id && port.product_id == product_id &&
                      (serial_number.empty() || port.serial_number == serial_number);
    if (same) matches.push_back(port);
    present.push_back(std::move(port));
  }
  if (matches.size() == 1) return matches.front().path;
  std::string wanted = usb_id(vendor_id, product_id);
  if (const auto known = classify_usb_device(vendor_id, product_id)) wanted += fmt::format(" ({})", known->description);
  if (!serial_number.empty()) wanted += fmt::format(" with serial number '{}'", serial_number);
  if (matches.size() > 1)
    return std::unexpected(
        fmt::format("{} USB serial devices {} are connected ({}); add the serial number "
                    "(usb:VID:PID:SERIAL) or name the port (serial:PATH)",
                    matches.size(), wanted, device_list(matches)));
  if (present.empty())
    return std::unexpected(
        fmt::format("no USB serial device {} is connected; no USB serial devices are present", wanted));
  return std::unexpected(
      fmt::format("no USB serial device {} is connected; present: {}", wanted, device_list(present)));
}

}  // namespace skinspec::drivers
