// The two ends of a memory pair share two one-way channels: each end reads from one and
// writes to the other. A channel carries, under its own mutex, the bytes in flight, whether
// each of its two ends is open, the reading end's interrupt flag (the only place that end
// ever blocks) and the modem lines its writing end set.

#include "skinspec/drivers/memory_transport.hpp"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <mutex>

namespace skinspec::drivers {

namespace detail {

struct MemoryChannel {
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<char> bytes;
  bool writer_open = true, reader_open = true;
  bool reader_interrupted = false;
  std::vector<ModemLines> writer_lines;
};

}  // namespace detail

namespace {

using Kind = TransportError::Kind;

std::unexpected<TransportError> fail(Kind kind, std::string message) {
  return std::unexpected(TransportError{kind, std::move(message)});
}

}  // namespace

MemoryTransport::MemoryTransport(std::string name, std::shared_ptr<detail::MemoryChannel> incoming,
                                 std::shared_ptr<detail::MemoryChannel> outgoing)
    : name_(std::move(name)), incoming_(std::move(incoming)), outgoing_(std::move(outgoing)) {}

// The peer must learn that this end is gone, as it would from a real connection.
MemoryTransport::~MemoryTransport() { close(); }

std::expected<void, TransportError> MemoryTransport::open() {
  {
    std::lock_guard lock(incoming_->mutex);
    incoming_->reader_open = true;
  }
  std::lock_guard lock(outgoing_->mutex);
  outgoing_->writer_open = true;
  return {};
}

// Like a serial port, closing discards what arrived and was not read.
void MemoryTransport::close() {
  {
    std::lock_guard lock(incoming_->mutex);
    incoming_->reader_open = false;
    incoming_->bytes.clear();
  }
  incoming_->changed.notify_all();
  {
    std::lock_guard lock(outgoing_->mutex);
    outgoing_->writer_open = false;
  }
  outgoing_->changed.notify_all();
}

bool MemoryTransport::is_open() const {
  std::lock_guard lock(incoming_->mutex);
  return incoming_->reader_open;
}

std::expected<void, TransportError> MemoryTransport::flush_input() {
  std::lock_guard lock(incoming_->mutex);
  if (!incoming_->reader_open) return fail(Kind::closed, name_ + ": not open");
  incoming_->bytes.clear();
  return {};
}

std::expected<void, TransportError> MemoryTransport::write(std::string_view bytes, Deadline) {
  {
    std::lock_guard lock(incoming_->mutex);
    if (incoming_->reader_interrupted) return fail(Kind::interrupted, name_ + ": interrupted");
  }
  {
    std::lock_guard lock(outgoing_->mutex);
    if (!outgoing_->writer_open) return fail(Kind::closed, name_ + ": not open");
    if (!outgoing_->reader_open) return fail(Kind::closed, name_ + ": the peer closed its end");
    outgoing_->bytes.insert(outgoing_->bytes.end(), bytes.begin(), bytes.end());
  }
  outgoing_->changed.notify_all();
  return {};
}

std::expected<std::size_t, TransportError> MemoryTransport::read(char* buffer, std::size_t size, Deadline deadline) {
  std::unique_lock lock(incoming_->mutex);
  auto& channel = *incoming_;
  const bool woken = channel.changed.wait_until(lock, deadline, [&] {
    return channel.reader_interrupted || !channel.reader_open || !channel.bytes.empty() || !channel.writer_open;
  });
  if (channel.reader_interrupted) return fail(Kind::interrupted, name_ + ": interrupted");
  if (!channel.reader_open) return fail(Kind::closed, name_ + ": not open");
  if (!channel.bytes.empty()) {
    const std::size_t n = std::min(size, channel.bytes.size());
    std::copy_n(channel.bytes.begin(), n, buffer);
    channel.bytes.erase(channel.bytes.begin(), channel.bytes.begin() + static_cast<std::ptrdiff_t>(n));
    return n;
  }
  if (!woken) return fail(Kind::timeout, name_ + ": nothing received before the deadline");
  return fail(Kind::closed, name_ + ": the peer closed its end");
}

std::expected<void, TransportError> MemoryTransport::set_modem_lines(bool dtr, bool rts) {
  std::lock_guard lock(outgoing_->mutex);
  if (!outgoing_->writer_open) return fail(Kind::closed, name_ + ": not open");
  outgoing_->writer_lines.push_back({dtr, rts});
  return {};
}

bool MemoryTransport::peer_closed() {
  std::lock_guard lock(incoming_->mutex);
  return incoming_->reader_open && !incoming_->writer_open;
}

void MemoryTransport::interrupt() {
  {
    std::lock_guard lock(incoming_->mutex);
    incoming_->reader_interrupted = true;
  }
  incoming_->changed.notify_all();
}

void MemoryTransport::clear_interrupt() {
  std::lock_guard lock(incoming_->mutex);
  incoming_->reader_interrupted = false;
}

std::string MemoryTransport::describe() const { return name_; }

std::vector<ModemLines> MemoryTransport::modem_line_changes() const {
  std::lock_guard lock(outgoing_->mutex);
  return outgoing_->writer_lines;
}

std::vector<ModemLines> MemoryTransport::peer_modem_line_changes() const {
  std::lock_guard lock(incoming_->mutex);
  return incoming_->writer_lines;
}

std::pair<std::unique_ptr<Transport>, std::unique_ptr<Transport>> make_memory_pair(std::string name) {
  auto a_to_b = std::make_shared<detail::MemoryChannel>();
  auto b_to_a = std::make_shared<detail::MemoryChannel>();
  return {std::make_unique<MemoryTransport>(name + ":a", b_to_a, a_to_b),
          std::make_unique<MemoryTransport>(name + ":b", a_to_b, b_to_a)};
}

}  // namespace skinspec::drivers
