#include "skinspec/simulator/recording.hpp"

#include <cmath>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::simulator {

namespace {

using Millis = std::chrono::duration<double, std::milli>;

bool ends_line(std::string_view tx) { return !tx.empty() && (tx.back() == '\n' || tx.back() == '\r'); }

// The PR-650 knows no keywords: "PHOTO" there is only the start of a line.
bool ends_command(std::string_view tx, drivers::Model model) {
  return drivers::profile(model).caps.remote_keyword ? drivers::pr6xx::command_complete(tx) : ends_line(tx);
}

double rounded_ms(drivers::Clock::duration d, double scale) {
  const double ms = Millis(d).count() / (scale > 0 ? scale : 1);
  return std::round(ms * 1000) / 1000;
}

}  // namespace

RecordingTransport::RecordingTransport(std::unique_ptr<drivers::Transport> inner, RecordingHeader header,
                                       RecordingOptions options)
    : inner_(std::move(inner)), options_(options) {
  recording_.header = std::move(header);
}

Recording RecordingTransport::recording() const {
  std::lock_guard lock(mutex_);
  return recording_;
}

std::expected<void, drivers::TransportError> RecordingTransport::open() { return inner_->open(); }
void RecordingTransport::close() { inner_->close(); }
bool RecordingTransport::is_open() const { return inner_->is_open(); }

// What the meter sent and the client throws away was still sent: it goes into the recording.
std::expected<void, drivers::TransportError> RecordingTransport::flush_input() {
  char buffer[512];
  while (true) {
    auto n = inner_->read(buffer, sizeof buffer, drivers::Clock::now());
    if (!n || *n == 0) break;
    received({buffer, *n});
  }
  return inner_->flush_input();
}

std::expected<void, drivers::TransportError> RecordingTransport::write(std::string_view bytes,
                                                                       drivers::Deadline deadline) {
  auto written = inner_->write(bytes, deadline);
  if (!written) return written;
  std::lock_guard lock(mutex_);
  const auto now = drivers::Clock::now();
  auto& exchanges = recording_.exchanges;
  // A command may be written in pieces; anything after a terminator or a reply is a new one.
  if (exchanges.empty() || !exchanges.back().rx.empty() || ends_command(exchanges.back().tx, recording_.header.model)) {
    exchanges.emplace_back().tx = bytes;
    timing_.push_back({now, now, now, 0, 0});
  } else {
    exchanges.back().tx += bytes;
    timing_.back().sent = now;
  }
  return written;
}

std::expected<std::size_t, drivers::TransportError> RecordingTransport::read(char* buffer, std::size_t size,
                                                                             drivers::Deadline deadline) {
  auto n = inner_->read(buffer, size, deadline);
  if (n && *n > 0) received({buffer, *n});
  return n;
}

void RecordingTransport::received(std::string_view bytes) {
  std::lock_guard lock(mutex_);
  const auto now = drivers::Clock::now();
  if (recording_.exchanges.empty()) {
    recording_.exchanges.push_back(Exchange{});
    timing_.push_back({now, now, now, 0, 0});
  }
  Exchange& exchange = recording_.exchanges.back();
  Timing& timing = timing_.back();
  if (timing.bytes == 0) {
    timing.first = now;
    timing.first_chunk = bytes.size();
    exchange.delay_ms = rounded_ms(now - timing.sent, options_.time_scale);
  }
  timing.last = now;
  timing.bytes += bytes.size();
  exchange.rx += bytes;
  // Bytes come in chunks: the time from the first chunk to the last, over the bytes after the
  // first chunk. A reply that came in one piece keeps the nominal line rate.
  if (const std::size_t later = timing.bytes - timing.first_chunk; later > 0)
    exchange.byte_interval_ms =
        rounded_ms((timing.last - timing.first) / static_cast<long>(later), options_.time_scale);
}

std::expected<void, drivers::TransportError> RecordingTransport::set_modem_lines(bool dtr, bool rts) {
  return inner_->set_modem_lines(dtr, rts);
}
bool RecordingTransport::peer_closed() { return inner_->peer_closed(); }
void RecordingTransport::interrupt() { inner_->interrupt(); }
void RecordingTransport::clear_interrupt() { inner_->clear_interrupt(); }
std::string RecordingTransport::describe() const { return inner_->describe(); }

}  // namespace skinspec::simulator
