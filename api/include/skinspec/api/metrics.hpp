#pragma once
// Counters and latency histograms for GET /metrics, in the Prometheus text format.
// Thread-safe: the server's threads record into one instance.

#include <array>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace skinspec::api {

class Metrics {
 public:
  // One request answered: its route template ("GET /api/v1/fits/{id}", or "unmatched"), status
  // and time spent in the router.
  void record_request(const std::string& route, int status, std::chrono::nanoseconds latency);
  void record_error(const std::string& code);
  void record_fit(bool ok);
  void set_open_connections(std::int64_t n);
  // The server's I/O threads, each counted from 0 before any connection comes.
  void set_io_threads(std::size_t count);
  // A connection taken in by I/O thread `io_thread` (0 for the listener's own).
  void record_accepted_connection(std::size_t io_thread);
  void record_rejected_connection();
  // An idle connection closed to make room for a newcomer.
  void record_evicted_connection();
  // Requests on the compute pool (fits, renders): running and waiting.
  void set_compute_load(std::size_t running, std::size_t waiting);

  std::string prometheus_text() const;

  static constexpr std::array<double, 10> kBuckets = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.5, 2.5};

 private:
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> counts{};
    std::uint64_t count = 0;
    double sum = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;
  std::map<std::string, std::uint64_t> errors_;
  std::map<std::size_t, std::uint64_t> accepted_by_io_thread_;
  std::uint64_t fits_ok_ = 0, fits_failed_ = 0, rejected_connections_ = 0, evicted_connections_ = 0;
  std::size_t compute_running_ = 0, compute_waiting_ = 0;
  std::int64_t open_connections_ = 0;
};

}  // namespace skinspec::api
