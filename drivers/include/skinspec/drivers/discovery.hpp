#pragma once
// Finding serial ports, the Photo Research meters on USB and the USB-serial adapters a PR-650
// is reached through, and noticing when they come and go. libserialport lists the ports; libusb
// adds what it cannot see (strings of the USB device) and reports hot-plug events. Where
// hot-plug is unsupported (containers, no udev) a polling monitor takes its place.

#include <chrono>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::drivers {

struct PortInfo {
  std::string path;         // /dev/ttyUSB0
  std::string description;  // libserialport's description
  std::string kind;         // "usb", "native", "bluetooth", "unknown"
  std::optional<unsigned short> vendor_id, product_id;
  std::string serial_number, manufacturer, product;
};

// What a USB serial device is: a Photo Research meter itself (the PR-655/670/680 and PR-7xx
// are USB CDC-ACM devices, /dev/ttyACM*), or an RS-232 adapter that a PR-650 is plugged into.
enum class UsbDeviceKind { photo_research_meter, rs232_adapter };

// "photo-research-meter", "rs232-adapter": the names in JSON.
std::string_view to_string(UsbDeviceKind kind);

// One row of the table of USB devices skinspec knows (packaging/udev grants access to each).
struct KnownUsbDevice {
  unsigned short vendor_id = 0;
  std::optional<unsigned short> product_id;  // none: any product of this vendor
  UsbDeviceKind kind = UsbDeviceKind::rs232_adapter;
  std::string_view description;  // "Photo Research meter", "FTDI FT232R RS-232 adapter"
};

// The table, one row per device: exact vendor and product first, a whole vendor after.
std::span<const KnownUsbDevice> known_usb_devices();

// The row for this vendor and product: an exact match, else a row for the whole vendor (a
// Photo Research product id no source documents), else none.
std::optional<KnownUsbDevice> classify_usb_device(unsigned short vendor_id, unsigned short product_id);

// The same for a port: none for a port without a USB vendor and product id.
std::optional<KnownUsbDevice> classify_port(const PortInfo& port);

// Every serial port the system has, USB ones with their identity.
std::vector<PortInfo> list_ports();

// The connection URI that reaches this port even after the kernel renumbers the ttys:
// usb:VID:PID[:SERIAL] for a USB device, serial:PATH otherwise.
std::string stable_uri(const PortInfo& port);

// The tty of the USB device (adapter or meter) with this identity today; an error naming the
// identity and the USB serial devices that are present otherwise.
std::expected<std::string, std::string> find_usb_port(unsigned short vendor_id, unsigned short product_id,
                                                      const std::string& serial_number = {});

struct UsbDeviceEvent {
  enum class Kind { attached, detached } kind;
  unsigned short vendor_id = 0, product_id = 0;
  std::string serial_number;  // may be empty (unknown or unreadable)
};

class HotplugMonitor {
 public:
  using Callback = std::function<void(const UsbDeviceEvent&)>;

  // Starts watching: libusb hot-plug where the platform has it, polling every `poll_interval`
  // otherwise. The callback runs on the monitor's own thread.
  static std::unique_ptr<HotplugMonitor> start(Callback callback,
                                               std::chrono::milliseconds poll_interval = std::chrono::seconds(1));
  virtual ~HotplugMonitor() = default;
  virtual bool polling() const = 0;  // true when hot-plug was unavailable
  virtual void stop() = 0;           // idempotent; the destructor stops too
};

}  // namespace skinspec::drivers
