#include "common/remote_session.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <thread>

#include "common/text.hpp"
#include "skinspec/drivers/identification.hpp"

namespace skinspec::drivers::remote {

namespace p6 = pr6xx;
using namespace std::chrono_literals;

namespace {

std::unexpected<InstrumentError> fail(InstrumentError::Kind kind, std::string message, std::string raw = {}) {
  return std::unexpected(InstrumentError{kind, std::move(message), -1, std::move(raw)});
}

std::string seconds(std::chrono::milliseconds t) {
  return fmt::format("{:.3g} s", static_cast<double>(t.count()) / 1000);
}

}  // namespace

std::string printable(std::string_view command) {
  std::string out(command);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

std::chrono::milliseconds whole_reply(const RemoteTiming& timing, int points) {
  const double bytes = 64.0 + 16.0 * points;  // a data line is at most "1080,1.234e-003\r\n"
  return timing.idle + std::chrono::milliseconds(static_cast<long>(1000 * bytes / timing.line_bytes_per_second));
}

Session::Session(Transport& transport, std::string_view meter_name, std::chrono::milliseconds pacing,
                 const RemoteTiming& timing, const pr6xx::CommandStyle& style)
    : transport_(transport), name_(meter_name), pacing_(pacing), timing_(timing), style_(style) {}

void Session::cancel() {
  {
    std::lock_guard lock(pause_mutex_);
    cancelled_ = true;
  }
  pause_cv_.notify_all();
  transport_.interrupt();
}

void Session::reset_cancel() {
  cancelled_ = false;
  transport_.clear_interrupt();
}

bool Session::pause(std::chrono::milliseconds how_long) {
  std::unique_lock lock(pause_mutex_);
  return !pause_cv_.wait_for(lock, how_long, [this] { return cancelled_.load(); });
}

InstrumentError Session::link_error(const TransportError& error, std::string_view command) const {
  using K = TransportError::Kind;
  if (error.kind == K::interrupted || cancelled_) return {InstrumentError::Kind::cancelled, "cancelled", -1, {}};
  if (error.kind == K::timeout)
    return {InstrumentError::Kind::lost,
            fmt::format("the {} on {} did not take '{}' in time; is it still on and connected?", name_,
                        transport_.describe(), printable(command)),
            -1,
            {}};
  return {
      InstrumentError::Kind::lost,
      fmt::format("lost the {} on {} during '{}': {}", name_, transport_.describe(), printable(command), error.message),
      -1,
      {}};
}

InstrumentError Session::unanswered(std::string_view command, const Reply& reply) const {
  if (reply.end == ReplyEnd::cut)
    return {InstrumentError::Kind::protocol,
            fmt::format("the reply to '{}' stopped after {} bytes", printable(command), reply.bytes.size()), -1,
            reply.bytes};
  return {InstrumentError::Kind::lost,
          fmt::format("the {} on {} did not answer '{}'; is it still on and connected?", name_, transport_.describe(),
                      printable(command)),
          -1,
          {}};
}

std::expected<void, InstrumentError> Session::open(std::chrono::milliseconds modem_settle) {
  if (!transport_.is_open())
    if (auto opened = transport_.open(); !opened)
      return fail(InstrumentError::Kind::transport,
                  fmt::format("cannot open {}: {}", transport_.describe(), opened.error().message));
  (void)transport_.set_modem_lines(false, false);
  std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(modem_settle, 100ms));
  (void)transport_.set_modem_lines(true, true);
  std::this_thread::sleep_for(modem_settle);
  return {};
}

// One byte at a time, never two within `pacing` of each other, across commands too: the meters
// lose a byte that follows the one before too closely (the makers' and the field's drivers wait
// 50 ms between bytes). Only the wait before a command's first byte yields to cancel(): once a
// byte is out, the command goes out whole and its reply is waited for briefly (settle), so that
// the meter never takes what comes next, Q above all, as the rest of it.
std::expected<void, InstrumentError> Session::write_paced(std::string_view command, Pacing pacing, const Rule* reply) {
  const bool yields = pacing == Pacing::yields;
  const std::size_t step = pacing_ > 0ms ? 1 : command.size();
  for (std::size_t i = 0; i < command.size(); i += step) {
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(last_byte_ + pacing_ - Clock::now());
    const bool first = yields && i == 0;
    if (first && ((wait > 0ms && !pause(wait)) || cancelled_))
      return fail(InstrumentError::Kind::cancelled, "cancelled");
    if (!first && wait > 0ms) std::this_thread::sleep_for(wait);
    const std::string_view bytes = command.substr(i, step);
    auto written = first ? transport_.write(bytes, deadline_in(timing_.reply)) : write_uninterrupted(bytes);
    if (!written) {
      if (first && written.error().kind == TransportError::Kind::interrupted)
        return fail(InstrumentError::Kind::cancelled, "cancelled");
      return std::unexpected(link_error(written.error(), command));
    }
    last_byte_ = Clock::now();
  }
  if (yields && cancelled_) return settle(reply);
  return {};
}

// cancel() interrupts the transport, perhaps just after the interrupt was cleared: one more try.
std::expected<void, TransportError> Session::write_uninterrupted(std::string_view bytes) {
  std::expected<void, TransportError> written;
  for (int attempt = 1; attempt <= 2; ++attempt) {
    transport_.clear_interrupt();
    written = transport_.write(bytes, deadline_in(timing_.reply));
    if (written || written.error().kind != TransportError::Kind::interrupted) return written;
  }
  return written;
}

// After a command that a cancel overtook while it went out: its reply (one line, or the whole
// reply `reply` describes), waited for no longer than `settle`, whatever it says. What has not
// come by then is dropped before the next command. The call ends cancelled all the same.
std::unexpected<InstrumentError> Session::settle(const Rule* reply) {
  const p6::ReplyShape shape = reply ? reply->shape : p6::ReplyShape::line;
  const int points = reply ? reply->points : 0;
  std::string received;
  char buffer[256];
  const Deadline end = deadline_in(timing_.settle);
  while (p6::reply_size(shape, received, points) == 0 && Clock::now() < end) {
    transport_.clear_interrupt();
    auto n = transport_.read(buffer, sizeof buffer, end);
    if (n) received.append(buffer, *n);
    else if (n.error().kind != TransportError::Kind::interrupted) break;
  }
  if (reply && p6::reply_size(shape, received, points) == 0)
    stray_.expect(received.empty() ? deadline_in(reply->first_byte) : Clock::now(),
                  deadline_in(reply->first_byte + reply->whole));
  return fail(InstrumentError::Kind::cancelled, "cancelled");
}

// A command and the wait for its reply: the first byte within the rule's time, then no pause
// longer than `idle` until reply_size() says it is whole. A banner in front of the reply (the
// meter holds it back until the next reply) and an echo are not part of it.
std::expected<Reply, InstrumentError> Session::transact(std::string_view command, const Rule& rule, bool flush) {
  if (cancelled_ || !stray_.drop(transport_, timing_.idle)) return fail(InstrumentError::Kind::cancelled, "cancelled");
  if (flush)
    if (auto flushed = transport_.flush_input(); !flushed) return std::unexpected(link_error(flushed.error(), command));
  if (auto written = write_paced(command, Pacing::yields, &rule); !written) return std::unexpected(written.error());
  const std::string_view echo = std::string_view(command).substr(0, printable(command).size());
  std::string received;
  Deadline next = deadline_in(rule.first_byte);
  std::optional<Deadline> whole;
  char buffer[512];
  for (;;) {
    const p6::BannerSplit split = p6::split_banner(received);
    const std::string_view reply =
        split.found == p6::BannerSplit::Found::partial ? std::string_view() : p6::strip_echo(split.rest, echo);
    if (const std::size_t size = p6::reply_size(rule.shape, reply, rule.points); size > 0)
      return Reply{ReplyEnd::complete, std::string(reply.substr(0, size))};
    auto n = transport_.read(buffer, sizeof buffer, whole ? std::min(next, *whole) : next);
    if (!n) {
      // Cancelled while the reply was due or coming: the meter sends the rest all the same.
      if (n.error().kind == TransportError::Kind::interrupted) stray_.expect_rest(whole, next, rule.whole);
      if (n.error().kind != TransportError::Kind::timeout) return std::unexpected(link_error(n.error(), command));
      if (reply.empty()) return Reply{ReplyEnd::silent, {}};
      if (rule.shape == p6::ReplyShape::listing) return Reply{ReplyEnd::complete, std::string(reply)};
      return Reply{ReplyEnd::cut, std::string(reply)};
    }
    received.append(buffer, *n);
    // The LF of the reply before, come after its CR was taken as the line's end, is not this
    // reply's first byte: taken as one, it would cut an M5's reply at the first pause of its
    // measurement.
    if (!whole && received.find_first_not_of("\r\n") == std::string::npos) {
      received.clear();
      continue;
    }
    if (!whole) {
      whole = deadline_in(rule.whole);
      ++replies_;
    }
    next = deadline_in(rule.idle);
  }
}

std::expected<Reply, InstrumentError> Session::transact_despite_cancel(std::string_view command, const Rule& rule) {
  const bool was = cancelled_.exchange(false);
  transport_.clear_interrupt();
  auto reply = transact(command, rule);
  if (was) cancelled_ = true;
  return reply;
}

void Session::expect_stray_reply(const Rule& rule) {
  stray_.expect(deadline_in(rule.first_byte), deadline_in(rule.first_byte + rule.whole));
}

// What came after PHOTO: the banner whole, other bytes, or nothing (an empty string).
std::expected<std::string, InstrumentError> Session::read_banner(std::chrono::milliseconds first_byte) {
  std::string received;
  Deadline next = deadline_in(first_byte);
  char buffer[256];
  for (;;) {
    const auto found = p6::split_banner(received).found;
    if (found == p6::BannerSplit::Found::whole) return received;
    auto n = transport_.read(buffer, sizeof buffer, next);
    if (!n) {
      if (n.error().kind != TransportError::Kind::timeout) return std::unexpected(link_error(n.error(), "PHOTO"));
      return received;
    }
    received.append(buffer, *n);
    next = deadline_in(timing_.idle);
  }
}

std::expected<bool, InstrumentError> Session::enter_remote() {
  if (!stray_.drop(transport_, timing_.idle)) return fail(InstrumentError::Kind::cancelled, "cancelled");
  // Q first: a meter that a crashed program left in remote mode ignores PHOTO.
  if (auto flushed = transport_.flush_input(); !flushed) return std::unexpected(link_error(flushed.error(), "Q"));
  if (auto q = write_paced(p6::kQuit); !q) return std::unexpected(q.error());
  if (!pause(timing_.quit_pause)) return fail(InstrumentError::Kind::cancelled, "cancelled");
  const Rule confirm{p6::ReplyShape::line, 0, timing_.confirm, timing_.idle, timing_.reply, false};
  for (int attempt = 1; attempt <= 2; ++attempt) {
    (void)transport_.flush_input();
    if (auto photo = write_paced(p6::kRemoteKeyword); !photo) return std::unexpected(photo.error());
    auto answer = read_banner(timing_.banner);
    if (!answer) return std::unexpected(answer.error());
    if (p6::split_banner(*answer).found == p6::BannerSplit::Found::whole) {
      ++replies_;
      set_remote(true);
      return false;
    }
    if (!answer->empty()) {
      if (identification::classify_photo(*answer) != identification::PhotoAnswer::newer_meter)
        return std::unexpected(not_remote_mode("PHOTO", *answer));
      ++replies_;
      set_remote(true);
      return true;
    }
    // Some meters hold the banner back until the next reply: without a flush, D111 shows it.
    auto reply = transact(p6::format_report(111, style_), confirm, false);
    if (!reply) return std::unexpected(reply.error());
    // A reply cut short is judged by what the second PHOTO brings.
    switch (reply->end == ReplyEnd::cut ? identification::PhotoAnswer::silence
                                        : identification::classify_photo(reply->bytes)) {
      case identification::PhotoAnswer::silence:
        break;
      case identification::PhotoAnswer::banner:
      case identification::PhotoAnswer::newer_meter:
        set_remote(true);
        return true;
      case identification::PhotoAnswer::pr650:
      case identification::PhotoAnswer::other:
        return std::unexpected(not_remote_mode("D111", reply->bytes));
    }
    if (attempt == 1) {
      if (auto q = write_paced(p6::kQuit); !q) return std::unexpected(q.error());
      if (!pause(timing_.retry_pause)) return fail(InstrumentError::Kind::cancelled, "cancelled");
    }
  }
  return fail(InstrumentError::Kind::no_contact,
              fmt::format("no answer from a {} on {} to PHOTO, twice within {}. The meter needs Power Saving off, "
                          "the USB cable, and no other program holding the port; if it still refuses, switch it "
                          "off and on",
                          name_, transport_.describe(), seconds(timing_.banner + timing_.confirm)));
}

// The meter answered, but not as a newer meter does: a PR-650 (in echo mode, it sends back
// what it gets) or something else.
InstrumentError Session::not_remote_mode(std::string_view command, std::string_view answer) const {
  if (identification::classify_photo(answer) == identification::PhotoAnswer::pr650)
    return {InstrumentError::Kind::identification,
            fmt::format("a PR-650 answered {} on {} ({}: it echoed the command, as a PR-650 in echo mode does), "
                        "not a {}; use --model pr650 or auto",
                        command, transport_.describe(), detail::quoted(answer), name_),
            -1, std::string(answer)};
  return {InstrumentError::Kind::identification,
          fmt::format("the device on {} answered {} with {}, which no {} sends: not a Photo Research meter?", command,
                      transport_.describe(), detail::quoted(answer), name_),
          -1, std::string(answer)};
}

// Q alone: a command a cancel cut short was finished before the cancelled call returned, and
// the pacing wait before Q does not yield to a cancel that comes meanwhile.
void Session::quit() {
  if (!remote_) return;
  if (transport_.is_open()) {
    transport_.clear_interrupt();
    (void)write_paced(p6::kQuit, Pacing::whole);
  }
  set_remote(false);
}

void Session::set_remote(bool remote) {
  remote_ = remote;
  if (!remote) listing_.reset();
  else if (!listing_) listing_.emplace(transport_.native_handle());
}

}  // namespace skinspec::drivers::remote
