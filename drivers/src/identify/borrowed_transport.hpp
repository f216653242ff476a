#pragma once
// A transport lent to a driver by the one that owns it (private to drivers/): identification
// keeps the link while it tries one family's driver after another, and closes it itself.

#include <string>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers::identify {

class BorrowedTransport final : public Transport {
 public:
  explicit BorrowedTransport(Transport& owner) : owner_(owner) {}

  std::expected<void, TransportError> open() override { return owner_.open(); }
  // The owner closes the link: a driver given up on must not close it for the next one.
  void close() override {}
  bool is_open() const override { return owner_.is_open(); }
  std::expected<void, TransportError> flush_input() override { return owner_.flush_input(); }
  std::expected<void, TransportError> write(std::string_view bytes, Deadline deadline) override {
    return owner_.write(bytes, deadline);
  }
  std::expected<std::size_t, TransportError> read(char* buffer, std::size_t size, Deadline deadline) override {
    return owner_.read(buffer, size, deadline);
  }
  std::expected<void, TransportError> set_modem_lines(bool dtr, bool rts) override {
    return owner_.set_modem_lines(dtr, rts);
  }
  bool peer_closed() override { return owner_.peer_closed(); }
  int native_handle() const override { return owner_.native_handle(); }
  void interrupt() override { owner_.interrupt(); }
  void clear_interrupt() override { owner_.clear_interrupt(); }
  std::string describe() const override { return owner_.describe(); }

 private:
  Transport& owner_;
};

}  // namespace skinspec::drivers::identify
