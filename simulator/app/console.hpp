#pragma once
// What skinspec-sim tells its user: addresses on standard output, one flushed line each, so
// that a script or test can read them; events and errors on standard error. Any thread.

#include <mutex>
#include <string_view>

namespace skinspec::sim_app {

class Console {
 public:
  explicit Console(bool quiet = false) : quiet_(quiet) {}

  // "listening on 127.0.0.1:40123", "pty /dev/pts/3": standard output, flushed at once.
  void announce(std::string_view line);
  // An event (a client, a fault that fired, a power cycle); not shown with --quiet.
  void note(std::string_view line);
  // Always shown.
  void error(std::string_view line);

 private:
  bool quiet_;
  std::mutex mutex_;
};

}  // namespace skinspec::sim_app
