#pragma once
// Two transports joined back to back in one process: what one end writes the other reads.
// For unit tests of drivers and for running the simulator in-process, with the same deadline,
// interrupt and close behaviour as a real port, and a record of the modem lines a driver set.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

// One set_modem_lines() call: {DTR, RTS}.
using ModemLines = std::pair<bool, bool>;

namespace detail {
struct MemoryChannel;
}

// One end of a memory pair. Both ends are open when made. Closing an end ends its peer's
// reads with `closed` once the peer has read what was already sent, and its peer's writes at
// once; open() after close() joins the end up again. Writes never block: the queues grow.
class MemoryTransport final : public Transport {
 public:
  MemoryTransport(std::string name, std::shared_ptr<detail::MemoryChannel> incoming,
                  std::shared_ptr<detail::MemoryChannel> outgoing);
  ~MemoryTransport() override;

  std::expected<void, TransportError> open() override;
  void close() override;
  bool is_open() const override;
  std::expected<void, TransportError> flush_input() override;
  std::expected<void, TransportError> write(std::string_view bytes, Deadline deadline) override;
  std::expected<std::size_t, TransportError> read(char* buffer, std::size_t size, Deadline deadline) override;
  std::expected<void, TransportError> set_modem_lines(bool dtr, bool rts) override;
  bool peer_closed() override;
  void interrupt() override;
  void clear_interrupt() override;
  std::string describe() const override;

  // Every set_modem_lines() call made on this end, in order (repeats included).
  std::vector<ModemLines> modem_line_changes() const;
  // The same for the other end: what a simulated instrument would see on its lines.
  std::vector<ModemLines> peer_modem_line_changes() const;

 private:
  std::string name_;
  std::shared_ptr<detail::MemoryChannel> incoming_, outgoing_;
};

// Two connected ends, described as "<name>:a" and "<name>:b". To see the modem lines of an
// end handed to a driver, keep `dynamic_cast<MemoryTransport&>(*end)` before moving it.
std::pair<std::unique_ptr<Transport>, std::unique_ptr<Transport>> make_memory_pair(std::string name = "memory");

}  // namespace skinspec::drivers
