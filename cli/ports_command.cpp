// skinspec ports: the serial ports this machine has, the Photo Research meter or USB adapter
// behind each, to find what to put in a connection URI (serial:PATH or usb:VID:PID[:SERIAL]).

#include <iostream>

#include "common.hpp"
#include "ports_format.hpp"
#include "skinspec/drivers/discovery.hpp"

namespace skinspec::cli {

void add_ports_command(CLI::App& app) {
  auto json = std::make_shared<bool>(false);
  auto* ports =
      app.add_subcommand("ports", "list serial ports and the Photo Research meters or USB adapters behind them");
  ports->add_flag("--json", *json, "print one JSON array of ports instead of a table");
  ports->callback([json] {
    const auto found = drivers::list_ports();
    std::cout << (*json ? ports_json_line(found) : ports_table(found));
  });
}

}  // namespace skinspec::cli
