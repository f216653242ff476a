// Noticing USB adapters and meters come and go. With libusb hot-plug, events are delivered as
// the kernel reports them and cover every USB device. Where libusb cannot start or has no
// hot-plug (containers, no udev), the monitor compares the USB serial ports libserialport lists
// every poll interval instead; that sees only USB serial devices (RS-232 adapters and the newer
// meters' own CDC-ACM ports), the only devices a caller here cares about. Devices present at
// start are not reported.

#include <fmt/format.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "discovery/usb_devices.hpp"
#include "skinspec/drivers/discovery.hpp"

namespace skinspec::drivers {

namespace {

using namespace std::chrono_literals;

// The monitor's thread. A callback may stop its own monitor: the thread cannot join itself,
// so it is left to end on its own and joined by whoever stops or destroys the monitor later.
// (Destroying the monitor from its callback is not supported.)
class MonitorThread {
 public:
  ~MonitorThread() {
    if (thread_.joinable() && thread_.get_id() == std::this_thread::get_id()) thread_.detach();
  }
  template <typename Body>
  void start(Body body) {
    thread_ = std::thread(std::move(body));
  }
  void join() {
    if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
  }

 private:
  std::thread thread_;
};

// ---- Polling ----------------------------------------------------------------------------

// The USB serial devices present, by a key that changes when a device is replaced.
std::map<std::string, UsbDeviceEvent> usb_serial_adapters() {
  std::map<std::string, UsbDeviceEvent> adapters;
  for (const auto& port : list_ports()) {
    if (port.kind != "usb" || !port.vendor_id || !port.product_id) continue;
    UsbDeviceEvent device{UsbDeviceEvent::Kind::attached, *port.vendor_id, *port.product_id, port.serial_number};
    adapters.emplace(
        fmt::format("{} {:04x}:{:04x} {}", port.path, device.vendor_id, device.product_id, device.serial_number),
        device);
  }
  return adapters;
}

class PollingMonitor final : public HotplugMonitor {
 public:
  PollingMonitor(Callback callback, std::chrono::milliseconds interval)
      : callback_(std::move(callback)), interval_(std::max<std::chrono::milliseconds>(interval, 10ms)) {
    thread_.start([this] { run(); });
  }
  ~PollingMonitor() override { stop(); }
  bool polling() const override { return true; }
  void stop() override {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

 private:
  void run() {
    auto known = usb_serial_adapters();
    while (wait_interval()) {
      auto present = usb_serial_adapters();
      report_changes(known, present);
      known = std::move(present);
    }
  }

  // False once stop() was called: the wait ends at once then.
  bool wait_interval() {
    std::unique_lock lock(mutex_);
    return !wake_.wait_for(lock, interval_, [this] { return stopping_; });
  }

  void report_changes(const std::map<std::string, UsbDeviceEvent>& before,
                      const std::map<std::string, UsbDeviceEvent>& after) {
    for (const auto& [key, device] : before)
      if (!after.contains(key)) report(UsbDeviceEvent::Kind::detached, device);
    for (const auto& [key, device] : after)
      if (!before.contains(key)) report(UsbDeviceEvent::Kind::attached, device);
  }

  void report(UsbDeviceEvent::Kind kind, UsbDeviceEvent event) {
    event.kind = kind;
    callback_(event);
  }

  Callback callback_;
  std::chrono::milliseconds interval_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  MonitorThread thread_;
};

// ---- libusb hot-plug --------------------------------------------------------------------

class LibusbMonitor final : public HotplugMonitor {
 public:
  // Null where this platform or container gives no hot-plug events.
  // Takes the callback only when it succeeds, so the polling monitor can have it otherwise.
  static std::unique_ptr<LibusbMonitor> try_start(Callback& callback) {
    auto monitor = std::unique_ptr<LibusbMonitor>(new LibusbMonitor());
    if (!monitor->context_.get() || !libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) return nullptr;
    const int events = LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT;
    if (libusb_hotplug_register_callback(monitor->context_.get(), events, 0, LIBUSB_HOTPLUG_MATCH_ANY,
                                         LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, &LibusbMonitor::on_event,
                                         monitor.get(), &monitor->handle_) != LIBUSB_SUCCESS)
      return nullptr;
    monitor->registered_ = true;
    monitor->callback_ = std::move(callback);
    monitor->thread_.start([raw = monitor.get()] { raw->run(); });
    return monitor;
  }

  ~LibusbMonitor() override {
    stop();
    for (const auto& pending : pending_) libusb_unref_device(pending.device);
    if (registered_) libusb_hotplug_deregister_callback(context_.get(), handle_);
  }
  bool polling() const override { return false; }
  void stop() override {
    stopping_ = true;
    if (context_.get()) libusb_interrupt_event_handler(context_.get());
    thread_.join();
  }

 private:
  struct Pending {
    libusb_device* device;
    UsbDeviceEvent::Kind kind;
  };

  LibusbMonitor() = default;

  // The short timeout bounds how long stop() can take should the interruption be missed.
  // A failing event loop is retried at the same pace rather than spun on.
  void run() {
    while (!stopping_) {
      timeval timeout{0, 100'000};
      const int result = libusb_handle_events_timeout_completed(context_.get(), &timeout, nullptr);
      if (result < 0 && result != LIBUSB_ERROR_INTERRUPTED) std::this_thread::sleep_for(100ms);
      deliver_pending();
    }
  }

  // libusb forbids blocking device I/O inside its callback, so the event is only queued
  // there, and the serial number read afterwards.
  static int LIBUSB_CALL on_event(libusb_context*, libusb_device* device, libusb_hotplug_event event, void* self) {
    const auto kind =
        event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED ? UsbDeviceEvent::Kind::attached : UsbDeviceEvent::Kind::detached;
    static_cast<LibusbMonitor*>(self)->pending_.push_back({libusb_ref_device(device), kind});
    return 0;  // stay registered
  }

  void deliver_pending() {
    auto pending = std::move(pending_);
    pending_.clear();
    for (const auto& [device, kind] : pending) {
      const UsbDeviceEvent event = describe(device, kind);
      libusb_unref_device(device);
      if (!stopping_) callback_(event);
    }
  }

  // A device that left can no longer be asked for its serial number: it is remembered from
  // its arrival, by bus and address.
  UsbDeviceEvent describe(libusb_device* device, UsbDeviceEvent::Kind kind) {
    UsbDeviceEvent event{kind, 0, 0, {}};
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(device, &descriptor) == LIBUSB_SUCCESS) {
      event.vendor_id = descriptor.idVendor;
      event.product_id = descriptor.idProduct;
    }
    const auto where = std::pair(libusb_get_bus_number(device), libusb_get_device_address(device));
    if (kind == UsbDeviceEvent::Kind::attached) {
      event.serial_number = detail::read_usb_strings(device).serial_number;
      serials_[where] = event.serial_number;
    } else if (auto known = serials_.find(where); known != serials_.end()) {
      event.serial_number = known->second;
      serials_.erase(known);
    }
    return event;
  }

  Callback callback_;
  detail::UsbContext context_;
  libusb_hotplug_callback_handle handle_{};
  bool registered_ = false;
  std::atomic<bool> stopping_{false};
  std::vector<Pending> pending_;  // touched only by the monitor's thread
  std::map<std::pair<int, int>, std::string> serials_;
  MonitorThread thread_;
};

}  // namespace

std::unique_ptr<HotplugMonitor> HotplugMonitor::start(Callback callback, std::chrono::milliseconds poll_interval) {
  if (auto monitor = LibusbMonitor::try_start(callback)) return monitor;
  return std::make_unique<PollingMonitor>(std::move(callback), poll_interval);
}

}  // namespace skinspec::drivers
