#include "instrument_link.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace skinspec::daemon {

using nlohmann::json;

namespace {

bool is_usb_device(const drivers::PortInfo& port) { return port.vendor_id && port.product_id; }

// What `auto` takes first: a meter of the documented product id, then one of another Photo
// Research product id, then an RS-232 adapter of the known ones, then any USB serial device.
enum class AutoRank { meter, unverified_meter, known_adapter, other_usb_device };

AutoRank auto_rank(const drivers::PortInfo& port) {
  const auto known = drivers::classify_port(port);
  if (!known) return AutoRank::other_usb_device;
  if (known->kind == drivers::UsbDeviceKind::rs232_adapter) return AutoRank::known_adapter;
  return known->product_id ? AutoRank::meter : AutoRank::unverified_meter;
}

json text_or_null(std::optional<std::string_view> text) { return text ? json(std::string(*text)) : json(nullptr); }

drivers::ConnectionUri serial_uri(const std::string& path) {
  drivers::ConnectionUri uri;
  uri.scheme = drivers::ConnectionUri::Scheme::serial;
  uri.path = path;
  return uri;
}

}  // namespace

std::optional<drivers::PortInfo> auto_device(std::vector<drivers::PortInfo> ports) {
  std::erase_if(ports, [](const auto& port) { return !is_usb_device(port); });
  const auto first = std::ranges::min_element(ports, [](const auto& a, const auto& b) {
    return std::pair(auto_rank(a), a.path) < std::pair(auto_rank(b), b.path);
  });
  if (first == ports.end()) return std::nullopt;
  return *first;
}

std::expected<ResolvedDevice, std::string> resolve_device(const std::string& device) {
  if (device == "auto") {
    const auto chosen = auto_device(drivers::list_ports());
    if (!chosen) return std::unexpected("no USB serial adapter found, and no Photo Research meter on USB");
    return ResolvedDevice{serial_uri(chosen->path),
                          UsbIdentity{*chosen->vendor_id, *chosen->product_id, chosen->serial_number}};
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
    if (is_usb_device(port)) {
      const auto known = drivers::classify_port(port);
      usb = {{"vid", fmt::format("{:04x}", *port.vendor_id)},
             {"pid", fmt::format("{:04x}", *port.product_id)},
             {"serial", port.serial_number},
             {"manufacturer", port.manufacturer},
             {"product", port.product},
             {"device_kind", text_or_null(known.transform([](const auto& k) { return drivers::to_string(k.kind); }))},
             {"device_description", text_or_null(known.transform([](const auto& k) { return k.description; }))}};
    }
    list.push_back({{"uri", drivers::stable_uri(port)},
                    {"name", port.path},
                    {"description", port.description},
                    {"transport", port.kind},
                    {"usb", usb}});
  }
  return {{"ports", list}};
}

}  // namespace skinspec::daemon
