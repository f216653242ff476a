#include "skinspec/drivers/emergency_quit.hpp"

#include <unistd.h>

#include <array>
#include <atomic>
#include <csignal>
#include <ctime>

namespace skinspec::drivers {

namespace {

// A few slots suffice: a service holds one meter, a test a handful. A link that finds none
// free goes unlisted, which costs only this last resort. Each holds its descriptor + 1, so that
// the zero every static starts with means free.
std::array<std::atomic<int>, 16> g_listed{};

constexpr std::array kFatalSignals = {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};
std::array<struct sigaction, kFatalSignals.size()> g_previous{};

void on_fatal_signal(int signal, siginfo_t* info, void* context) {
  send_emergency_quit();
  for (std::size_t i = 0; i < kFatalSignals.size(); ++i) {
    if (kFatalSignals[i] != signal) continue;
    const struct sigaction& previous = g_previous[i];
    if ((previous.sa_flags & SA_SIGINFO) != 0 && previous.sa_sigaction != nullptr) {
      previous.sa_sigaction(signal, info, context);
      return;
    }
    if (previous.sa_handler != SIG_DFL && previous.sa_handler != SIG_IGN && previous.sa_handler != nullptr) {
      previous.sa_handler(signal);
      return;
    }
  }
  // Die of it as before: the default action, raised again once this handler returns.
  ::signal(signal, SIG_DFL);
  ::raise(signal);
}

}  // namespace

// A CR first ends whatever command the crash cut short ("D11" becomes a report the meter
// refuses harmlessly), so that Q arrives as a command of its own. There is no waiting for that
// reply here; only the meters' byte pacing (50 ms, nanosleep being async-signal-safe) keeps the
// Q from following the CR too closely to be kept.
void send_emergency_quit() noexcept {
  constexpr timespec kPacing{0, 50'000'000};
  bool any = false;
  for (auto& slot : g_listed)
    if (const int fd = slot.load() - 1; fd >= 0) {
      const ssize_t ignored = ::write(fd, "\r", 1);
      static_cast<void>(ignored);
      any = true;
    }
  if (!any) return;
  ::nanosleep(&kPacing, nullptr);
  for (auto& slot : g_listed)
    if (const int fd = slot.load() - 1; fd >= 0) {
      const ssize_t ignored = ::write(fd, "Q", 1);
      static_cast<void>(ignored);
    }
}

void install_emergency_quit() {
  for (std::size_t i = 0; i < kFatalSignals.size(); ++i) {
    struct sigaction action {};
    action.sa_sigaction = on_fatal_signal;
    action.sa_flags = SA_SIGINFO | SA_RESETHAND;
    sigemptyset(&action.sa_mask);
    sigaction(kFatalSignals[i], &action, &g_previous[i]);
  }
}

EmergencyQuitListing::EmergencyQuitListing(int fd) noexcept {
  if (fd < 0) return;
  for (std::size_t i = 0; i < g_listed.size(); ++i) {
    int expected = 0;
    if (g_listed[i].compare_exchange_strong(expected, fd + 1)) {
      slot_ = static_cast<int>(i);
      return;
    }
  }
}

EmergencyQuitListing::~EmergencyQuitListing() {
  if (slot_ >= 0) g_listed[static_cast<std::size_t>(slot_)].store(0);
}

}  // namespace skinspec::drivers
