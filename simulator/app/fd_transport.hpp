#pragma once
// A drivers::Transport over a file descriptor: an accepted TCP connection or the master side
// of a pseudo-terminal. The descriptor is made non-blocking; every wait is a poll() that an
// eventfd can cut short, so interrupt() works from any thread.

#include <atomic>
#include <string>

#include "skinspec/drivers/transport.hpp"
#include "unique_fd.hpp"

namespace skinspec::sim_app {

class FdTransport final : public drivers::Transport {
 public:
  // owned: close() closes the descriptor (a client's socket). borrowed: close() only stops
  // using it (the pseudo-terminal, which outlives its clients), and open() takes it up again.
  enum class Ownership { owned, borrowed };

  FdTransport(int fd, std::string label, Ownership ownership);
  ~FdTransport() override;
  FdTransport(const FdTransport&) = delete;
  FdTransport& operator=(const FdTransport&) = delete;

  std::expected<void, drivers::TransportError> open() override;
  void close() override;
  bool is_open() const override;
  std::expected<void, drivers::TransportError> flush_input() override;
  std::expected<void, drivers::TransportError> write(std::string_view bytes, drivers::Deadline deadline) override;
  std::expected<std::size_t, drivers::TransportError> read(char* buffer, std::size_t size,
                                                           drivers::Deadline deadline) override;
  // Neither a socket nor a pseudo-terminal has modem lines worth setting.
  std::expected<void, drivers::TransportError> set_modem_lines(bool dtr, bool rts) override;
  void interrupt() override;
  void clear_interrupt() override;
  std::string describe() const override;

 private:
  enum class Wait { ready, timeout, interrupted, failed };
  Wait wait_for(short events, drivers::Deadline deadline) const;

  int fd_;
  Ownership ownership_;
  bool open_ = true;
  std::string label_;
  UniqueFd wake_;  // eventfd: written by interrupt()
  std::atomic<bool> interrupted_{false};
};

}  // namespace skinspec::sim_app
