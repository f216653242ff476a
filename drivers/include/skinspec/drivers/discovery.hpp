#pragma once
// Finding serial ports and USB-serial adapters, and noticing when adapters come and go.
// libserialport lists the ports; libusb adds what it cannot see (strings of the USB device)
// and reports hot-plug events. Where hot-plug is unsupported (containers, no udev) a polling
// monitor takes its place.

#include <chrono>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::drivers {

struct PortInfo {
  std::string path;         // /dev/ttyUSB0
  std::string description;  // libserialport's description
  std::string kind;         // "usb", "native", "bluetooth", "unknown"
  std::optional<unsigned short> vendor_id, product_id;
  std::string serial_number, manufacturer, product;
};

// Every serial port the system has, USB ones with their identity.
std::vector<PortInfo> list_ports();

// The tty of the USB adapter with this identity today; an error naming the identity and the
// adapters that are present otherwise.
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
