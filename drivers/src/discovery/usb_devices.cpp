#include "discovery/usb_devices.hpp"

#include <cstdint>
#include <memory>

namespace skinspec::drivers::detail {

UsbContext::UsbContext() {
  if (libusb_init(&context_) != LIBUSB_SUCCESS) context_ = nullptr;
}

UsbContext::~UsbContext() {
  if (context_) libusb_exit(context_);
}

namespace {

struct HandleCloser {
  void operator()(libusb_device_handle* handle) const { libusb_close(handle); }
};

std::string read_string(libusb_device_handle* handle, std::uint8_t index) {
  if (index == 0) return {};  // the device has no such string
  unsigned char text[256];
  const int length = libusb_get_string_descriptor_ascii(handle, index, text, sizeof text);
  if (length <= 0) return {};
  return std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(length));
}

}  // namespace

UsbStrings read_usb_strings(libusb_device* device) {
  libusb_device_descriptor descriptor{};
  if (libusb_get_device_descriptor(device, &descriptor) != LIBUSB_SUCCESS) return {};
  libusb_device_handle* raw = nullptr;
  if (libusb_open(device, &raw) != LIBUSB_SUCCESS) return {};
  const std::unique_ptr<libusb_device_handle, HandleCloser> handle(raw);
  return {read_string(raw, descriptor.iSerialNumber), read_string(raw, descriptor.iManufacturer),
          read_string(raw, descriptor.iProduct)};
}

std::optional<UsbStrings> usb_strings_at(const UsbContext& context, int bus, int address) {
  if (!context.get()) return std::nullopt;
  libusb_device** devices = nullptr;
  const ssize_t count = libusb_get_device_list(context.get(), &devices);
  if (count < 0) return std::nullopt;
  std::optional<UsbStrings> found;
  for (ssize_t i = 0; i < count && !found; ++i)
    if (libusb_get_bus_number(devices[i]) == bus && libusb_get_device_address(devices[i]) == address)
      found = read_usb_strings(devices[i]);
  libusb_free_device_list(devices, 1);
  return found;
}

}  // namespace skinspec::drivers::detail
