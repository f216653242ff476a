#pragma once
// One connection to a newer meter (PR-655 and later) in remote mode: commands written a byte at
// a time at the profile's pace, stale bytes flushed before each, every reply freed of a glued
// " REMOTE MODE" banner and of any echo before it is measured and parsed. PHOTO enters remote
// mode (after a Q, for a meter a crashed program left remote), Q leaves it. Pr6xx and Pr7xx
// share it; the PR-650 speaks differently (pr650/driver.cpp).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <expected>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/drivers/stray_reply.hpp"
#include "skinspec/drivers/emergency_quit.hpp"
#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/remote_options.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers::remote {

// How long one reply may take and what to do when it is lost or damaged.
struct Rule {
  pr6xx::ReplyShape shape = pr6xx::ReplyShape::line;
  int points = 0;                           // data lines of a spectral reply (D120's count)
  std::chrono::milliseconds first_byte{0};  // from the command's last byte to the reply's first
  std::chrono::milliseconds idle{0};
  std::chrono::milliseconds whole{0};  // from the first byte to the last
  bool ask_again = true;               // setups and reports change nothing: a lost one is asked again once
};

enum class ReplyEnd { complete, silent, cut };
struct Reply {
  ReplyEnd end = ReplyEnd::silent;
  std::string bytes;  // banner and echo removed
};

class Session {
 public:
  Session(Transport& transport, std::string_view meter_name, std::chrono::milliseconds pacing,
          const RemoteTiming& timing, const pr6xx::CommandStyle& style);

  // Opens the port and wiggles DTR/RTS as the makers' software does.
  std::expected<void, InstrumentError> open(std::chrono::milliseconds modem_settle);
  // Q, PHOTO, and the banner or a confirming D111; a second PHOTO after Q and a pause if both
  // were silent. Returns whether the banner came glued to the D111's reply. An answer no newer
  // meter gives (a PR-650's echo, other bytes) is an `identification` error.
  std::expected<bool, InstrumentError> enter_remote();
  // Takes the meter as remote: another session on the same link entered remote mode.
  void assume_remote() { set_remote(true); }
  // Q when remote: the meter's screen stays locked otherwise. Works after cancel().
  void quit();
  bool remote() const { return remote_; }

  // A command and its reply. The reply of an exchange a cancel cut short is read and dropped
  // first (stray_reply.hpp).
  std::expected<Reply, InstrumentError> transact(std::string_view command, const Rule& rule, bool flush = true);
  // The same, even when cancel() was called: for the abort that a cancel itself sends.
  std::expected<Reply, InstrumentError> transact_despite_cancel(std::string_view command, const Rule& rule);
  // A reply parsed, asked again once where the rule says so when lost, cut short or garbled.
  template <typename Parse>
  auto ask(std::string_view command, const Rule& rule, std::string_view what, Parse parse)
      -> std::expected<typename decltype(parse(std::string_view()))::value_type, InstrumentError>;
  // A reply that may come within `rule.first_byte` although no command asked for it now (a
  // measurement a cancel could not stop): dropped before the next command.
  void expect_stray_reply(const Rule& rule);
  // Waits, cut short by cancel(); false when cancelled.
  bool pause(std::chrono::milliseconds how_long);

  void cancel();
  void reset_cancel();
  bool cancelled() const { return cancelled_; }
  std::uint64_t replies() const { return replies_; }

  InstrumentError unanswered(std::string_view command, const Reply& reply) const;
  InstrumentError link_error(const TransportError& error, std::string_view command) const;

 private:
  // Whether the wait before a command's first byte yields to cancel(); Q's does not.
  enum class Pacing { yields, whole };
  // `reply`: how the command is answered, when a reply cut short by a cancel is to be dropped
  // before the next command.
  std::expected<void, InstrumentError> write_paced(std::string_view command, Pacing pacing = Pacing::yields,
                                                   const Rule* reply = nullptr);
  std::expected<void, TransportError> write_uninterrupted(std::string_view bytes);
  std::unexpected<InstrumentError> settle(const Rule* reply);
  std::expected<std::string, InstrumentError> read_banner(std::chrono::milliseconds first_byte);
  InstrumentError not_remote_mode(std::string_view command, std::string_view answer) const;
  // Remote mode entered or left, with the link on the emergency list (emergency_quit.hpp) while
  // remote.
  void set_remote(bool remote);

  Transport& transport_;
  std::string name_;
  std::chrono::milliseconds pacing_;
  RemoteTiming timing_;
  pr6xx::CommandStyle style_;
  bool remote_ = false;
  std::optional<EmergencyQuitListing> listing_;
  Clock::time_point last_byte_{};  // when the last byte went out, for the pacing
  StrayReply stray_;
  std::atomic<bool> cancelled_{false};
  std::atomic<std::uint64_t> replies_{0};
  std::mutex pause_mutex_;
  std::condition_variable pause_cv_;
};

// A command as logs and messages show it: without its line end.
std::string printable(std::string_view command);

// The cap on a whole reply of `points` data lines (0: one line), from the line rate.
std::chrono::milliseconds whole_reply(const RemoteTiming& timing, int points);

template <typename Parse>
auto Session::ask(std::string_view command, const Rule& rule, std::string_view what, Parse parse)
    -> std::expected<typename decltype(parse(std::string_view()))::value_type, InstrumentError> {
  InstrumentError failure{InstrumentError::Kind::protocol, "", -1, {}};
  const int tries = rule.ask_again ? 2 : 1;
  for (int attempt = 1; attempt <= tries; ++attempt) {
    Rule this_try = rule;
    if (attempt > 1) this_try.first_byte *= 2;  // a reply that was only late arrives now
    auto reply = transact(command, this_try);
    if (!reply) return std::unexpected(reply.error());
    if (reply->end != ReplyEnd::complete) {
      failure = unanswered(command, *reply);
      // The rest of a reply that stopped may still be on its way: not a reply to the next try,
      // which drops it first (transact).
      if (reply->end == ReplyEnd::cut) stray_.expect(Clock::now(), deadline_in(rule.whole));
      continue;
    }
    auto parsed = parse(reply->bytes);
    if (parsed) return *parsed;
    failure = {InstrumentError::Kind::protocol, std::string(what) + ": " + parsed.error().message, -1, reply->bytes};
  }
  if (tries > 1) failure.message += " (asked twice)";
  return std::unexpected(failure);
}

}  // namespace skinspec::drivers::remote
