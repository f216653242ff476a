#pragma once
// The last way out of remote mode. A newer meter (PR-655 and later) left in remote mode keeps
// its keys and touch screen locked until it is switched off, and a process that dies of a fatal
// signal never runs its drivers' disconnect. So every link in remote mode is listed here by its
// file descriptor, and a fatal-signal handler writes CR and Q to each with write(2) alone, which
// is async-signal-safe (the CR ends a command the crash cut short). SIGKILL cannot be caught: after kill -9 the meter
// stays locked.

namespace skinspec::drivers {

// Installs handlers for SIGSEGV, SIGBUS, SIGILL, SIGFPE and SIGABRT that send Q to every meter
// in remote mode, then let the process die of the same signal as it would have. Once, early in
// main(), after any other handler of these signals (a sanitizer's) is in place.
void install_emergency_quit();

// Writes CR, then 50 ms later Q, to every listed descriptor. Async-signal-safe.
void send_emergency_quit() noexcept;

// A descriptor on the list while the object lives (remote_session.cpp holds one per link in
// remote mode). A negative descriptor (a link with none, such as an in-process one) is not
// listed.
class EmergencyQuitListing {
 public:
  explicit EmergencyQuitListing(int fd) noexcept;
  ~EmergencyQuitListing();
  EmergencyQuitListing(const EmergencyQuitListing&) = delete;
  EmergencyQuitListing& operator=(const EmergencyQuitListing&) = delete;

 private:
  int slot_ = -1;
};

}  // namespace skinspec::drivers
