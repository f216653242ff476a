#pragma once
// A simulated PR-650 serving one end of an in-process link on its own thread, the scenes the
// simulator tests measure, and a raw client that speaks bytes to the meter.

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "data_dir.hpp"
#include "skinspec/drivers/memory_transport.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "support/driver_options.hpp"
#include "skinspec/simulator/meter.hpp"

namespace skinspec::testing {

using namespace std::chrono_literals;

inline const simulator::ColourData& colour_data() {
  static const simulator::ColourData data = *simulator::ColourData::load(directory_reader(SKINSPEC_TEST_DATA_DIR));
  return data;
}

inline const simulator::Observer& observer() { return colour_data().observer; }

// A flat reflectance under D65, so bright that a perfect white would have `white_luminance`.
inline simulator::Scene grey_scene(std::string name, double reflectance, double white_luminance) {
  const simulator::Lamp lamp{"D65", colour_data().d65, white_luminance};
  return simulator::scene_under_lamp(std::move(name), *Spectrum::create({380, 780}, {reflectance, reflectance}), lamp,
                                     observer());
}

inline simulator::Scene white_scene(double white_luminance = 100) {
  return grey_scene("white standard", 0.99, white_luminance);
}

// Forearm skin (data/examples/forearm.csv, the median subject) under D65.
inline simulator::Scene skin_scene(double white_luminance = 100) {
  auto bytes = read_file(std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv");
  const simulator::Lamp lamp{"D65", colour_data().d65, white_luminance};
  auto scenes = simulator::reflectance_scenes(*bytes, "forearm.csv", lamp, observer());
  return (*scenes)[1];
}

// Options for tests: no waiting, a window that never closes on its own, logs kept.
inline simulator::MeterOptions fast_meter() {
  simulator::MeterOptions o;
  o.time_scale = 0;
  o.boot_window_s = 3600;
  return o;
}

using testing::fast_driver;

// A meter serving the device end of a memory pair on a thread; the host end is for the test.
class MeterRig {
 public:
  MeterRig(simulator::ReadingSource source, simulator::MeterOptions options = fast_meter()) {
    options.log = [this](std::string_view line) {
      std::lock_guard lock(log_mutex_);
      log_.emplace_back(line);
    };
    meter_ = std::make_unique<simulator::SimulatedMeter>(std::move(source), std::move(options));
    auto [host, device] = drivers::make_memory_pair("sim");
    host_ = std::move(host);
    device_ = std::move(device);
    thread_ = std::thread([this] { end_ = meter_->serve(*device_, stop_); });
  }
  ~MeterRig() {
    stop_ = true;
    thread_.join();
  }

  simulator::SimulatedMeter& meter() { return *meter_; }
  // The host end; null once handed to a driver.
  drivers::Transport* host() { return host_.get(); }
  std::unique_ptr<drivers::Transport> take_host() { return std::move(host_); }
  std::unique_ptr<drivers::Pr650> driver(drivers::DriverOptions options = fast_driver()) {
    return std::make_unique<drivers::Pr650>(take_host(), options);
  }
  // Waits for serve() to return (a disconnect) and tells how it ended.
  std::optional<simulator::SimulatedMeter::ServeEnd> wait_for_end(std::chrono::milliseconds limit = 1s) {
    const auto until = std::chrono::steady_clock::now() + limit;
    while (!end_.load() && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(1ms);
    return end_.load();
  }
  std::vector<std::string> log() const {
    std::lock_guard lock(log_mutex_);
    return log_;
  }

 private:
  std::unique_ptr<simulator::SimulatedMeter> meter_;
  std::unique_ptr<drivers::Transport> host_, device_;
  std::atomic<bool> stop_{false};
  // How serve() ended, written once by the serving thread.
  class EndSlot {
   public:
    EndSlot& operator=(simulator::SimulatedMeter::ServeEnd v) {
      value_ = v;
      set_ = true;
      return *this;
    }
    std::optional<simulator::SimulatedMeter::ServeEnd> load() const {
      return set_ ? std::optional(value_) : std::nullopt;
    }

   private:
    std::atomic<bool> set_{false};
    simulator::SimulatedMeter::ServeEnd value_{};
  };
  EndSlot end_;
  std::thread thread_;
  mutable std::mutex log_mutex_;
  std::vector<std::string> log_;
};

// Collects what arrives, waiting up to `first` for the first byte, until the line has been
// quiet for `quiet`.
inline std::string listen(drivers::Transport& link, std::chrono::milliseconds quiet = 30ms,
                          std::chrono::milliseconds first = 1s) {
  std::string received;
  char buffer[2048];
  while (true) {
    auto n = link.read(buffer, sizeof buffer, drivers::deadline_in(received.empty() ? first : quiet));
    if (!n) return received;
    received.append(buffer, *n);
  }
}

// Discards what is pending, sends a command and collects the reply.
inline std::string ask(drivers::Transport& link, std::string_view command, std::chrono::milliseconds quiet = 30ms,
                       std::chrono::milliseconds first = 1s) {
  (void)link.flush_input();
  (void)link.write(command, drivers::deadline_in(1s));
  return listen(link, quiet, first);
}

// For a command that should get no answer: what came within 150 ms.
inline std::string ask_expecting_silence(drivers::Transport& link, std::string_view command) {
  return ask(link, command, 30ms, 150ms);
}

}  // namespace skinspec::testing
