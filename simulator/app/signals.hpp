#pragma once
// SIGTERM, SIGINT and SIGHUP as readable events on a descriptor (signalfd), so that the
// server's poll loop handles them in order with everything else and no handler runs at an odd
// moment. SIGPIPE is ignored: a client that goes away is seen as a failed write.

#include <expected>
#include <string>

#include "unique_fd.hpp"

namespace skinspec::sim_app {

class Signals {
 public:
  // Blocks the signals in the calling thread, and so in every thread it starts later: call it
  // before any thread exists.
  static std::expected<Signals, std::string> install();

  int fd() const { return fd_.get(); }
  // The next pending signal's number, or 0 when none is pending.
  int take() const;

 private:
  UniqueFd fd_;
};

}  // namespace skinspec::sim_app
