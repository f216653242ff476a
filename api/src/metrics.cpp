#include "skinspec/api/metrics.hpp"

#include <sstream>

namespace skinspec::api {

namespace {
// Label values are route templates and error codes of our own; escape anyway.
std::string escape_label(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}
}  // namespace

void Metrics::record_request(const std::string& route, int status, std::chrono::nanoseconds latency) {
  const double seconds = std::chrono::duration<double>(latency).count();
  std::lock_guard lock(mutex_);
  ++requests_[{route, status}];
  Histogram& h = latency_[route];
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (seconds <= kBuckets[i]) ++h.counts[i];
  ++h.count;
  h.sum += seconds;
}

void Metrics::record_error(const std::string& code) {
  std::lock_guard lock(mutex_);
  ++errors_[code];
}

void Metrics::record_fit(bool ok) {
  std::lock_guard lock(mutex_);
  ++(ok ? fits_ok_ : fits_failed_);
}

void Metrics::set_open_connections(std::int64_t n) {
  std::lock_guard lock(mutex_);
  open_connections_ = n;
}

void Metrics::set_io_threads(std::size_t count) {
  std::lock_guard lock(mutex_);
  for (std::size_t i = 0; i < count; ++i) accepted_by_io_thread_.try_emplace(i, 0);
}

void Metrics::record_accepted_connection(std::size_t io_thread) {
  std::lock_guard lock(mutex_);
  ++accepted_by_io_thread_[io_thread];
}

void Metrics::record_rejected_connection() {
  std::lock_guard lock(mutex_);
  ++rejected_connections_;
}

void Metrics::record_evicted_connection() {
  std::lock_guard lock(mutex_);
  ++evicted_connections_;
}

void Metrics::set_compute_load(std::size_t running, std::size_t waiting) {
  std::lock_guard lock(mutex_);
  compute_running_ = running;
  compute_waiting_ = waiting;
}

std::string Metrics::prometheus_text() const {
  std::lock_guard lock(mutex_);
  std::ostringstream out;
  out << "# HELP skinspec_http_requests_total Requests answered, by route and status.\n"
         "# TYPE skinspec_http_requests_total counter\n";
  for (const auto& [key, n] : requests_)
    out << "skinspec_http_requests_total{route=\"" << escape_label(key.first) << "\",status=\"" << key.second << "\"} "
        << n << '\n';
  out << "# HELP skinspec_http_request_duration_seconds Time spent answering, by route.\n"
         "# TYPE skinspec_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_) {
    const std::string label = escape_label(route);
    for (std::size_t i = 0; i < kBuckets.size(); ++i)
      out << "skinspec_http_request_duration_seconds_bucket{route=\"" << label << "\",le=\"" << kBuckets[i] << "\"} "
          << h.counts[i] << '\n';
    out << "skinspec_http_request_duration_seconds_bucket{route=\"" << label << "\",le=\"+Inf\"} " << h.count << '\n';
    out << "skinspec_http_request_duration_seconds_sum{route=\"" << label << "\"} " << h.sum << '\n';
    out << "skinspec_http_request_duration_seconds_count{route=\"" << label << "\"} " << h.count << '\n';
  }
  out << "# HELP skinspec_http_errors_total Error responses, by error code.\n"
         "# TYPE skinspec_http_errors_total counter\n";
  for (const auto& [code, n] : errors_)
    out << "skinspec_http_errors_total{code=\"" << escape_label(code) << "\"} " << n << '\n';
  out << "# HELP skinspec_fits_total Model fits run, by outcome.\n"
         "# TYPE skinspec_fits_total counter\n"
      << "skinspec_fits_total{outcome=\"ok\"} " << fits_ok_ << '\n'
      << "skinspec_fits_total{outcome=\"failed\"} " << fits_failed_ << '\n'
      << "# HELP skinspec_open_connections Connections open now.\n"
         "# TYPE skinspec_open_connections gauge\n"
      << "skinspec_open_connections " << open_connections_ << '\n'
      << "# HELP skinspec_accepted_connections_total Connections taken in, by the I/O thread that serves them.\n"
         "# TYPE skinspec_accepted_connections_total counter\n";
  for (const auto& [io_thread, n] : accepted_by_io_thread_)
    out << "skinspec_accepted_connections_total{io_thread=\"" << io_thread << "\"} " << n << '\n';
  out << "# HELP skinspec_rejected_connections_total Connections closed at once because the cap was reached.\n"
         "# TYPE skinspec_rejected_connections_total counter\n"
      << "skinspec_rejected_connections_total " << rejected_connections_ << '\n'
      << "# HELP skinspec_evicted_connections_total Idle connections closed to make room for new ones.\n"
         "# TYPE skinspec_evicted_connections_total counter\n"
      << "skinspec_evicted_connections_total " << evicted_connections_ << '\n'
      << "# HELP skinspec_compute_running Fits and renders running on the compute pool.\n"
         "# TYPE skinspec_compute_running gauge\n"
      << "skinspec_compute_running " << compute_running_ << '\n'
      << "# HELP skinspec_compute_waiting Fits and renders waiting for the compute pool.\n"
         "# TYPE skinspec_compute_waiting gauge\n"
      << "skinspec_compute_waiting " << compute_waiting_ << '\n';
  return out.str();
}

}  // namespace skinspec::api
