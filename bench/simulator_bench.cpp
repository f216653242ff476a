// The simulated PR-650 at time scale 0 over an in-process link. Goal: an M0 + D5 exchange
// (measure, then the 1733-byte spectral report) well under 2 ms, so that integration tests
// against the simulator stay fast. Also the driver's whole measurement (S, M0, D5, D1, D2).

#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "data_dir.hpp"
#include "skinspec/drivers/memory_transport.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "skinspec/simulator/meter.hpp"

namespace skinspec::simulator {
namespace {

namespace pp = drivers::pr650;

Synthesis white() {
  auto colour = ColourData::load(directory_reader(find_data_dir()));
  if (!colour) {
    std::fprintf(stderr, "simulator_bench: %s (set SKINSPEC_DATA_DIR)\n", colour.error().c_str());
    std::exit(1);
  }
  const Lamp d65{"D65", colour->d65, 100};
  auto flat = Spectrum::create({380, 780}, {0.99, 0.99});
  return Synthesis{colour->observer, {scene_under_lamp("white", *flat, d65, colour->observer)}};
}

// A meter serving the device end of a memory pair for as long as the benchmark runs.
struct Served {
  SimulatedMeter meter;
  std::unique_ptr<drivers::Transport> host, device;
  std::atomic<bool> stop{false};
  std::thread thread;

  Served() : meter(white(), options()) {
    auto [h, d] = drivers::make_memory_pair("bench");
    host = std::move(h);
    device = std::move(d);
    thread = std::thread([this] { meter.serve(*device, stop); });
  }
  ~Served() {
    stop = true;
    thread.join();
  }
  static MeterOptions options() {
    MeterOptions o;
    o.time_scale = 0;
    o.boot_window_s = 3600;
    return o;
  }
};

bool exchange(drivers::Transport& link, std::string_view command, pp::ReplyShape shape, std::string& received) {
  received.clear();
  if (!link.write(command, drivers::deadline_in(std::chrono::seconds(1)))) return false;
  char buffer[4096];
  while (!pp::reply_complete(shape, received)) {
    auto n = link.read(buffer, sizeof buffer, drivers::deadline_in(std::chrono::seconds(1)));
    if (!n) return false;
    received.append(buffer, *n);
  }
  return true;
}

void BM_M0_D5_Exchange(benchmark::State& state) {
  Served served;
  std::string received;
  for (auto _ : state) {
    if (!exchange(*served.host, "m0\n", pp::ReplyShape::line, received) ||
        !exchange(*served.host, "d5\n", pp::ReplyShape::spectral, received)) {
      state.SkipWithError("the simulated meter did not answer");
      break;
    }
    benchmark::DoNotOptimize(received.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * 1738);
}
BENCHMARK(BM_M0_D5_Exchange)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_DriverMeasurement(benchmark::State& state) {
  Served served;
  drivers::DriverOptions options;
  options.modem_settle = std::chrono::milliseconds(0);
  drivers::Pr650 driver(std::move(served.host), options);
  if (!driver.connect()) {
    state.SkipWithError("no contact with the simulated meter");
    return;
  }
  for (auto _ : state) {
    auto reading = driver.measure({});
    if (!reading) {
      state.SkipWithError(reading.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(reading->radiance.data());
  }
}
BENCHMARK(BM_DriverMeasurement)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace
}  // namespace skinspec::simulator

BENCHMARK_MAIN();
