// skinspec ports: the serial ports this machine has, and the USB adapter behind each, to find
// what to put in a connection URI (serial:PATH or usb:VID:PID[:SERIAL]).

#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "skinspec/drivers/discovery.hpp"

namespace skinspec::cli {

namespace {

using drivers::PortInfo;

std::string usb_id(const PortInfo& port) {
  if (!port.vendor_id || !port.product_id) return "";
  return fmt::format("{:04x}:{:04x}", *port.vendor_id, *port.product_id);
}

// The URI that reaches this port even after the kernel renumbers the ttys.
std::string stable_uri(const PortInfo& port) {
  if (usb_id(port).empty()) return "serial:" + port.path;
  return "usb:" + usb_id(port) + (port.serial_number.empty() ? "" : ":" + port.serial_number);
}

nlohmann::json port_json(const PortInfo& port) {
  nlohmann::json out = {{"path", port.path},
                        {"kind", port.kind},
                        {"description", port.description},
                        {"serial_number", port.serial_number},
                        {"manufacturer", port.manufacturer},
                        {"product", port.product},
                        {"uri", stable_uri(port)}};
  out["vendor_id"] = port.vendor_id ? nlohmann::json(fmt::format("{:04x}", *port.vendor_id)) : nlohmann::json(nullptr);
  out["product_id"] =
      port.product_id ? nlohmann::json(fmt::format("{:04x}", *port.product_id)) : nlohmann::json(nullptr);
  return out;
}

void print_table(const std::vector<PortInfo>& ports) {
  if (ports.empty()) {
    std::cout << "no serial ports found\n";
    return;
  }
  std::cout << fmt::format("{:<20} {:<9} {:<9} {:<16} {:<32} {}\n", "path", "kind", "usb_id", "serial", "uri",
                           "description");
  for (const auto& port : ports)
    std::cout << fmt::format("{:<20} {:<9} {:<9} {:<16} {:<32} {}\n", port.path, port.kind, usb_id(port),
                             printable(port.serial_number), printable(stable_uri(port)), printable(port.description));
}

}  // namespace

void add_ports_command(CLI::App& app) {
  auto json = std::make_shared<bool>(false);
  auto* ports = app.add_subcommand("ports", "list serial ports and the USB adapters behind them");
  ports->add_flag("--json", *json, "print one JSON array of ports instead of a table");
  ports->callback([json] {
    const auto found = drivers::list_ports();
    if (*json) {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& port : found) out.push_back(port_json(port));
      // A device's serial number and description are its own bytes, not always UTF-8.
      std::cout << out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
    } else {
      print_table(found);
    }
  });
}

}  // namespace skinspec::cli
