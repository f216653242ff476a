#include "ports_format.hpp"

#include <fmt/format.h>

#include "skinspec/spectral/utf8.hpp"

namespace skinspec::cli {

namespace {

using drivers::PortInfo;
using Json = nlohmann::json;

std::string usb_id(const PortInfo& port) {
  if (!port.vendor_id || !port.product_id) return "";
  return fmt::format("{:04x}:{:04x}", *port.vendor_id, *port.product_id);
}

Json hex_or_null(const std::optional<unsigned short>& id) {
  return id ? Json(fmt::format("{:04x}", *id)) : Json(nullptr);
}

std::string table_line(const std::string& path, const std::string& kind, const std::string& id,
                       const std::string& serial, const std::string& uri, const std::string& device,
                       const std::string& description) {
  return fmt::format("{:<20} {:<9} {:<9} {:<16} {:<32} {:<38} {}\n", path, kind, id, serial, uri, device, description);
}

}  // namespace

Json port_json(const PortInfo& port) {
  const auto known = drivers::classify_port(port);
  Json out = {{"path", port.path},
              {"kind", port.kind},
              {"description", port.description},
              {"serial_number", port.serial_number},
              {"manufacturer", port.manufacturer},
              {"product", port.product},
              {"uri", drivers::stable_uri(port)},
              {"vendor_id", hex_or_null(port.vendor_id)},
              {"product_id", hex_or_null(port.product_id)},
              {"device_kind", nullptr},
              {"device_description", nullptr}};
  if (known) {
    out["device_kind"] = std::string(drivers::to_string(known->kind));
    out["device_description"] = std::string(known->description);
  }
  return out;
}

// A device's serial number and description are its own bytes, not always UTF-8.
std::string ports_json_line(const std::vector<PortInfo>& ports) {
  Json out = Json::array();
  for (const auto& port : ports) out.push_back(port_json(port));
  return out.dump(-1, ' ', false, Json::error_handler_t::replace) + '\n';
}

std::string ports_table(const std::vector<PortInfo>& ports) {
  if (ports.empty()) return "no serial ports found\n";
  std::string table = table_line("path", "kind", "usb_id", "serial", "uri", "device", "description");
  for (const auto& port : ports) {
    const auto known = drivers::classify_port(port);
    table += table_line(printable(port.path), port.kind, usb_id(port), printable(port.serial_number),
                        printable(drivers::stable_uri(port)), known ? std::string(known->description) : "",
                        printable(port.description));
  }
  return table;
}

}  // namespace skinspec::cli
