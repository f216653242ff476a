// The USB serial devices skinspec recognises, as data. Photo Research's own driver file binds
// only 180b:0524 (docs/pr6xx-protocol.md); any other product of that vendor is listed as a
// Photo Research device whose product id no source confirms. The adapters are the common
// USB-serial bridges of RS-232 cables; packaging/udev/60-skinspec-usb-serial.rules grants
// access to exactly these rows (tests/drivers/discovery_test.cpp holds the two together).

#include <algorithm>
#include <array>

#include "skinspec/drivers/discovery.hpp"

namespace skinspec::drivers {

namespace {

using enum UsbDeviceKind;

constexpr std::array kKnownUsbDevices{
    KnownUsbDevice{0x180b, 0x0524, photo_research_meter, "Photo Research meter"},
    KnownUsbDevice{0x067b, 0x2303, rs232_adapter, "Prolific PL2303 RS-232 adapter"},
    KnownUsbDevice{0x0403, 0x6001, rs232_adapter, "FTDI FT232R RS-232 adapter"},
    KnownUsbDevice{0x0403, 0x6014, rs232_adapter, "FTDI FT232H RS-232 adapter"},
    KnownUsbDevice{0x0403, 0x6015, rs232_adapter, "FTDI FT-X RS-232 adapter"},
    KnownUsbDevice{0x10c4, 0xea60, rs232_adapter, "Silicon Labs CP210x RS-232 adapter"},
    KnownUsbDevice{0x1a86, 0x7523, rs232_adapter, "WCH CH340 RS-232 adapter"},
    KnownUsbDevice{0x1a86, 0x5523, rs232_adapter, "WCH CH341 RS-232 adapter"},
    KnownUsbDevice{0x180b, std::nullopt, photo_research_meter, "Photo Research (unverified product id)"},
};

}  // namespace

std::string_view to_string(UsbDeviceKind kind) {
  switch (kind) {
    case photo_research_meter:
      return "photo-research-meter";
    case rs232_adapter:
      return "rs232-adapter";
  }
  return "unknown";
}

std::span<const KnownUsbDevice> known_usb_devices() { return kKnownUsbDevices; }

std::optional<KnownUsbDevice> classify_usb_device(unsigned short vendor_id, unsigned short product_id) {
  const auto exact = std::ranges::find_if(kKnownUsbDevices, [&](const KnownUsbDevice& row) {
    return row.vendor_id == vendor_id && row.product_id == product_id;
  });
  if (exact != kKnownUsbDevices.end()) return *exact;
  const auto vendor = std::ranges::find_if(
      kKnownUsbDevices, [&](const KnownUsbDevice& row) { return row.vendor_id == vendor_id && !row.product_id; });
  if (vendor != kKnownUsbDevices.end()) return *vendor;
  return std::nullopt;
}

std::optional<KnownUsbDevice> classify_port(const PortInfo& port) {
  if (!port.vendor_id || !port.product_id) return std::nullopt;
  return classify_usb_device(*port.vendor_id, *port.product_id);
}

}  // namespace skinspec::drivers
