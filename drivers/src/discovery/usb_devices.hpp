#pragma once
// libusb, for what libserialport does not tell: the strings of a USB device and hot-plug.

#include <libusb.h>

#include <optional>
#include <string>

namespace skinspec::drivers::detail {

// A libusb context of our own, or none where libusb cannot start (containers without
// /dev/bus/usb): every user must cope with get() == nullptr.
class UsbContext {
 public:
  UsbContext();
  ~UsbContext();
  UsbContext(const UsbContext&) = delete;
  UsbContext& operator=(const UsbContext&) = delete;
  libusb_context* get() const { return context_; }

 private:
  libusb_context* context_ = nullptr;
};

struct UsbStrings {
  std::string serial_number, manufacturer, product;
};

// The strings need the device opened, which takes permission: without it they stay empty.
UsbStrings read_usb_strings(libusb_device* device);

// The strings of the device at this bus and address, if libusb sees it there.
std::optional<UsbStrings> usb_strings_at(const UsbContext& context, int bus, int address);

}  // namespace skinspec::drivers::detail
