#pragma once
// What `skinspec ports` prints, apart from the listing itself, so that the shapes can be checked
// with ports made up for the purpose (no machine running the tests has a meter attached).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/drivers/discovery.hpp"

namespace skinspec::cli {

// One port: {path, kind (the transport: "usb", "native", ...), description, serial_number,
// manufacturer, product, uri, vendor_id, product_id (4 hex digits or null), device_kind
// ("photo-research-meter", "rs232-adapter" or null), device_description (or null)}.
nlohmann::json port_json(const drivers::PortInfo& port);

// --json: one line, the array of port_json; bytes that are not UTF-8 replaced.
std::string ports_json_line(const std::vector<drivers::PortInfo>& ports);

// The table for people, a header and a line per port, the known device named in its own column.
std::string ports_table(const std::vector<drivers::PortInfo>& ports);

}  // namespace skinspec::cli
