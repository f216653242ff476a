// The simulated meter's wire: line framing, the power-on window, echo, faults on the bytes of
// each reply, and pacing. What a command means is the responder's business.

#include "skinspec/simulator/meter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>
#include <utility>

#include "reply_faults.hpp"
#include "responder.hpp"

namespace skinspec::simulator {

using namespace std::chrono_literals;
using drivers::Clock;
using Mode = SimulatedMeter::Mode;
using ServeEnd = SimulatedMeter::ServeEnd;

namespace {

constexpr auto kPoll = 20ms;           // how often serve() looks at `stop`
constexpr std::size_t kMaxLine = 256;  // longer lines overflow the meter's input buffer
constexpr double kDefaultLateMs = 1000;
constexpr auto kWriteTimeout = 5s;

using Millis = std::chrono::duration<double, std::milli>;

// Waits, looking at `stop` now and then; false when stopped.
bool wait(double ms, const std::atomic<bool>& stop) {
  const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(Millis(ms));
  while (!stop) {
    const auto now = Clock::now();
    if (now >= until) return true;
    std::this_thread::sleep_for(std::min<Clock::duration>(until - now, 10ms));
  }
  return false;
}

enum class Sent { ok, stopped, failed };

// The bytes at `interval_ms` each, written a few milliseconds' worth at a time: a client that
// ends a reply at the first silence of 50 ms (as some do) never sees a gap.
Sent send(drivers::Transport& link, const std::atomic<bool>& stop, std::string_view bytes, double interval_ms) {
  if (bytes.empty()) return Sent::ok;
  if (interval_ms <= 0) return link.write(bytes, drivers::deadline_in(kWriteTimeout)) ? Sent::ok : Sent::failed;
  const auto start = Clock::now();
  const auto chunk = static_cast<std::size_t>(std::max(1.0, std::floor(4.0 / interval_ms)));
  for (std::size_t sent = 0; sent < bytes.size();) {
    const std::size_t n = std::min(chunk, bytes.size() - sent);
    if (!link.write(bytes.substr(sent, n), drivers::deadline_in(kWriteTimeout))) return Sent::failed;
    sent += n;
    if (stop) return Sent::stopped;
    std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(Millis(sent * interval_ms)));
  }
  return Sent::ok;
}

// A reply after the faults that act on its bytes, and how it goes out.
struct Outgoing {
  std::string bytes;
  double delay_ms = 0;      // real time
  double interval_ms = 0;   // real time
  bool disconnect = false;  // close the link after the bytes
  bool prompt = false;      // echo mode: '>' when ready again
};

std::size_t cut_point(const Fault& fault, std::size_t size) {
  if (fault.amount < 0) return size / 2;
  return std::min(size, static_cast<std::size_t>(fault.amount));
}

}  // namespace

std::string_view to_string(Mode mode) {
  switch (mode) {
    case Mode::boot:
      return "boot";
    case Mode::remote:
      return "remote";
    case Mode::local:
      return "local";
  }
  return "unknown";
}

std::string_view to_string(ServeEnd end) {
  switch (end) {
    case ServeEnd::stopped:
      return "stopped";
    case ServeEnd::closed:
      return "closed";
    case ServeEnd::disconnected:
      return "disconnected";
  }
  return "unknown";
}

struct SimulatedMeter::Impl {
  MeterOptions options;
  std::unique_ptr<detail::Responder> responder;
  std::mt19937_64 rng;  // the bytes of garbage and bit flips, random lines

  mutable std::mutex mutex;  // everything below, and the responder
  Mode mode = Mode::boot;
  Clock::time_point powered_on = Clock::now();
  bool echo = false;
  std::size_t commands = 0;
  std::vector<std::string> problems;

  Impl(MeterOptions o) : options(std::move(o)), rng(options.seed ^ 0x5eed) {}

  void log(std::string_view text) const {
    if (options.log) options.log(text);
  }
  Mode current_mode() const;  // with the mutex held
  std::optional<Outgoing> take_command(std::string_view line);
  std::optional<Outgoing> take_unprompted();
  Outgoing outgoing(detail::Reply reply, const std::vector<Fault>& faults);
  std::optional<ServeEnd> transmit(drivers::Transport& link, const std::atomic<bool>& stop, const Outgoing& out);
};

Mode SimulatedMeter::Impl::current_mode() const {
  if (mode == Mode::boot && Clock::now() - powered_on > Millis(options.boot_window_s * 1000)) return Mode::local;
  return mode;
}

// What a complete command line makes the meter send, if anything.
std::optional<Outgoing> SimulatedMeter::Impl::take_command(std::string_view line) {
  const detail::Command command = detail::parse_command(line);
  std::lock_guard lock(mutex);
  ++commands;
  if (mode == Mode::boot) {
    mode = current_mode() == Mode::local ? Mode::local : Mode::remote;
    log(mode == Mode::remote ? "power-on window: first command in time, remote mode"
                             : "power-on window missed: local mode, silent until power-cycled");
  }
  if (mode == Mode::local) return std::nullopt;

  std::vector<Fault> faults = options.faults.next(command.key);
  for (const auto& fault : faults) log(fmt::format("fault {} on '{}'", fault.to_string(), command.text));
  const auto has = [&](FaultKind kind) {
    return std::ranges::any_of(faults, [&](const Fault& f) { return f.kind == kind; });
  };
  if (has(FaultKind::no_answer)) return std::nullopt;
  if (has(FaultKind::reboot)) {
    mode = Mode::local;
    echo = false;
    responder->power_cycle();
    log("rebooted: local mode, silent until power-cycled");
    return std::nullopt;
  }

  detail::Outcome outcome = responder->respond(command, faults);
  for (const auto& note : outcome.notes) log(note);
  for (auto& problem : outcome.problems) {
    log(problem);
    problems.push_back(std::move(problem));
  }
  if (!outcome.reply) {
    if (!echo) return std::nullopt;
    Outgoing prompt_only;
    prompt_only.prompt = true;
    return prompt_only;
  }
  if (outcome.reply->echo_on) echo = true;
  return outgoing(std::move(*outcome.reply), faults);
}

std::optional<Outgoing> SimulatedMeter::Impl::take_unprompted() {
  std::lock_guard lock(mutex);
  if (current_mode() == Mode::local) return std::nullopt;
  auto reply = responder->unprompted();
  if (!reply) return std::nullopt;
  return outgoing(std::move(*reply), {});
}

// Applies the faults that act on bytes, in the order a line would: content first, then noise,
// then the cut.
Outgoing SimulatedMeter::Impl::outgoing(detail::Reply reply, const std::vector<Fault>& faults) {
  Outgoing out;
  std::string bytes = std::move(reply.bytes);
  out.delay_ms = reply.delay_ms * options.time_scale;
  out.interval_ms = reply.byte_interval_ms * options.time_scale;
  out.prompt = echo;
  std::optional<std::size_t> cut;
  for (const Fault& f : faults) {
    switch (f.kind) {
      case FaultKind::quality:
        bytes = detail::with_quality(std::move(bytes), static_cast<int>(f.amount));
        break;
      case FaultKind::stale:
        log(fmt::format("fault {} acts on measurements only", f.to_string()));
        break;
      case FaultKind::exponent:
        bytes = detail::with_exponent(std::move(bytes), f.exponent);
        break;
      case FaultKind::header:
        bytes = detail::with_header(std::move(bytes), f.header);
        break;
      case FaultKind::line_count:
        bytes = detail::with_line_count(std::move(bytes), static_cast<int>(f.amount));
        break;
      case FaultKind::drop_line:
        bytes = detail::without_line(std::move(bytes), static_cast<int>(std::max(0.0, f.amount)), rng);
        break;
      case FaultKind::garbage:
        bytes = detail::with_garbage(std::move(bytes), f.amount < 0 ? 8 : static_cast<int>(f.amount), rng);
        break;
      case FaultKind::bitflip:
        bytes = detail::with_bitflips(std::move(bytes), f.amount < 0 ? 1 : static_cast<int>(f.amount), rng);
        break;
      case FaultKind::late:
        out.delay_ms += f.amount < 0 ? kDefaultLateMs : f.amount;
        break;
      case FaultKind::truncate:
      case FaultKind::disconnect:
      case FaultKind::no_answer:
      case FaultKind::reboot:
        break;
    }
  }
  for (const Fault& f : faults) {
    if (f.kind != FaultKind::truncate && f.kind != FaultKind::disconnect) continue;
    cut = std::min(cut.value_or(bytes.size()), cut_point(f, bytes.size()));
    if (f.kind == FaultKind::disconnect) out.disconnect = true;
  }
  if (cut) {
    bytes.resize(*cut);
    out.prompt = false;  // a meter cut short is not ready for more
  }
  out.bytes = std::move(bytes);
  return out;
}

std::optional<ServeEnd> SimulatedMeter::Impl::transmit(drivers::Transport& link, const std::atomic<bool>& stop,
                                                       const Outgoing& out) {
  if (!wait(out.delay_ms, stop)) return ServeEnd::stopped;
  switch (send(link, stop, out.bytes, out.interval_ms)) {
    case Sent::ok:
      break;
    case Sent::stopped:
      return ServeEnd::stopped;
    case Sent::failed:
      return ServeEnd::closed;
  }
  if (out.disconnect) {
    log(fmt::format("disconnect after {} bytes", out.bytes.size()));
    link.close();
    return ServeEnd::disconnected;
  }
  if (out.prompt && !link.write(">", drivers::deadline_in(kWriteTimeout))) return ServeEnd::closed;
  return std::nullopt;
}

SimulatedMeter::SimulatedMeter(ReadingSource source, MeterOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {
  if (auto* synthesis = std::get_if<Synthesis>(&source)) {
    impl_->responder = detail::make_instrument(std::move(*synthesis), impl_->options);
  } else {
    impl_->responder = detail::make_replayer(std::move(std::get<Recording>(source)), impl_->options);
  }
}

SimulatedMeter::~SimulatedMeter() = default;

SimulatedMeter::ServeEnd SimulatedMeter::serve(drivers::Transport& link, const std::atomic<bool>& stop) {
  Impl& m = *impl_;
  if (auto out = m.take_unprompted())
    if (auto end = m.transmit(link, stop, *out)) return *end;
  std::string line;
  char buffer[512];
  while (!stop) {
    auto n = link.read(buffer, sizeof buffer, drivers::deadline_in(kPoll));
    if (!n) {
      using Kind = drivers::TransportError::Kind;
      if (n.error().kind == Kind::timeout) continue;
      if (n.error().kind == Kind::interrupted) return ServeEnd::stopped;
      return ServeEnd::closed;
    }
    std::string echoed;
    for (std::size_t i = 0; i < *n; ++i) {
      const char c = buffer[i];
      {
        std::lock_guard lock(m.mutex);
        if (m.echo && m.mode == Mode::remote) echoed += c;
      }
      if (c != '\r' && c != '\n') {
        line += c;
        if (line.size() > kMaxLine) {
          m.log(fmt::format("input line longer than {} bytes dropped", kMaxLine));
          line.clear();
        }
        continue;
      }
      // The echo of a command goes out before its reply.
      if (!echoed.empty() && !link.write(std::exchange(echoed, {}), drivers::deadline_in(kWriteTimeout)))
        return ServeEnd::closed;
      if (line.empty()) continue;  // the LF of a CR LF, or a blank line
      auto out = m.take_command(std::exchange(line, {}));
      if (!out) continue;
      if (auto end = m.transmit(link, stop, *out)) return *end;
      if (auto more = m.take_unprompted())
        if (auto end = m.transmit(link, stop, *more)) return *end;
    }
    if (!echoed.empty() && !link.write(echoed, drivers::deadline_in(kWriteTimeout))) return ServeEnd::closed;
  }
  return ServeEnd::stopped;
}

void SimulatedMeter::power_cycle() {
  std::lock_guard lock(impl_->mutex);
  impl_->mode = Mode::boot;
  impl_->powered_on = Clock::now();
  impl_->echo = false;
  impl_->responder->power_cycle();
  impl_->log("power-cycled: power-on window open");
}

SimulatedMeter::Mode SimulatedMeter::mode() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->current_mode();
}

std::size_t SimulatedMeter::commands() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->commands;
}

std::size_t SimulatedMeter::measurements() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->responder->measurements();
}

std::vector<std::string> SimulatedMeter::problems() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->problems;
}

}  // namespace skinspec::simulator
