// PR-650 protocol speed. Goal: reading a D5 spectral report (1733 bytes, 101 lines) <= 20 us,
// so that parsing is negligible next to the 1.8 s the report takes to arrive at 9600 baud.

#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::drivers::pr650 {
namespace {

// A smooth, white-ish spectrum as the meter prints it.
const std::string& d5_reply() {
  static const std::string reply = [] {
    SpectralReport report;
    for (int i = 0; i < kSpectralPoints; ++i) {
      const double nm = kFirstNm + kStepNm * i;
      report.wavelength_nm.push_back(nm);
      report.values.push_back(1e-3 * (1.1 + std::sin(nm / 37.0)));
      report.integrated += 4 * report.values.back();
    }
    return format_spectral_reply(report);
  }();
  return reply;
}

void BM_ParseSpectral(benchmark::State& state) {
  const std::string& reply = d5_reply();
  for (auto _ : state) {
    auto report = parse_spectral(reply);
    benchmark::DoNotOptimize(report);
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(reply.size()));
}
BENCHMARK(BM_ParseSpectral);

// A driver asks this after every read while the report streams in.
void BM_ReplyCompleteSpectral(benchmark::State& state) {
  const std::string& reply = d5_reply();
  for (auto _ : state) {
    bool complete = reply_complete(ReplyShape::spectral, reply);
    benchmark::DoNotOptimize(complete);
  }
}
BENCHMARK(BM_ReplyCompleteSpectral);

void BM_FormatSpectral(benchmark::State& state) {
  const SpectralReport report = *parse_spectral(d5_reply());
  for (auto _ : state) {
    auto bytes = format_spectral_reply(report);
    benchmark::DoNotOptimize(bytes);
  }
}
BENCHMARK(BM_FormatSpectral);

}  // namespace
}  // namespace skinspec::drivers::pr650

BENCHMARK_MAIN();
