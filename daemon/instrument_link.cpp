#include "instrument_link.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace skinspec::daemon {

using nlohmann::json;

namespace {

bool is_usb_adapter(const drivers::PortInfo& port) { return port.vendor_id && port.product_id; }

drivers::ConnectionUri serial_uri(const std::string& path) {
  drivers::ConnectionUri uri;
  uri.scheme = drivers::ConnectionUri::Scheme::serial;
  uri.path = path;
  return uri;
}

}  // namespace

std::optional<drivers::PortInfo> first_usb_adapter(std::vector<drivers::PortInfo> ports) {
  std::sort(ports.begin(), ports.end(), [](const auto& a, const auto& b) { return a.path < b.path; });
  const auto it = std::find_if(ports.begin(), ports.end(), is_usb_adapter);
  if (it == ports.end()) return std::nullopt;
  return *it;
}

std::expected<ResolvedDevice, std::string> resolve_device(const std::string& device) {
  if (device == "auto") {
    const auto adapter = first_usb_adapter(drivers::list_ports());
    if (!adapter) return std::unexpected("no USB serial adapter found");
    return ResolvedDevice{serial_uri(adapter->path),
                          UsbIdentity{*adapter->vendor_id, *adapter->product_id, adapter->serial_number}};
  }
  auto uri = drivers::parse_connection_uri(device);
  if (!uri) return std::unexpected("--device '" + device + "': " + uri.error());
  if (uri->scheme != drivers::ConnectionUri::Scheme::usb) return ResolvedDevice{*uri, std::nullopt};
  auto path = drivers::find_usb_port(uri->vendor_id, uri->product_id, uri->usb_serial);
  if (!path) return std::unexpected(path.error());
  ResolvedDevice resolved{*uri, UsbIdentity{uri->vendor_id, uri->product_id, uri->usb_serial}};
  resolved.uri.scheme = drivers::ConnectionUri::Scheme::serial;  // baud, flow and terminator stay
  resolved.uri.path = *path;
  return resolved;
}

bool follows_usb_adapters(const std::string& device) { return device == "auto" || device.starts_with("usb:"); }

bool concerns(const drivers::UsbDeviceEvent& event, const UsbIdentity& adapter) {
  if (event.vendor_id != adapter.vendor_id || event.product_id != adapter.product_id) return false;
  return event.serial_number.empty() || adapter.serial_number.empty() || event.serial_number == adapter.serial_number;
}

json ports_json(const std::vector<drivers::PortInfo>& ports) {
  json list = json::array();
  for (const auto& port : ports) {
    json usb = nullptr;
    std::string uri = "serial:" + port.path;
    if (is_usb_adapter(port)) {
      usb = {{"vid", fmt::format("{:04x}", *port.vendor_id)},
             {"pid", fmt::format("{:04x}", *port.product_id)},
             {"serial", port.serial_number},
             {"manufacturer", port.manufacturer},
             {"product", port.product}};
      uri = fmt::format("usb:{:04x}:{:04x}{}", *port.vendor_id, *port.product_id,
                        port.serial_number.empty() ? std::string() : ":" + port.serial_number);
    }
    list.push_back(
        {{"uri", uri}, {"name", port.path}, {"description", port.description}, {"transport", port.kind}, {"usb", usb}});
  }
  return {{"ports", list}};
}

}  // namespace skinspec::daemon
