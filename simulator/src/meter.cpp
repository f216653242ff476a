// The simulated meter's wire: framing (framing.hpp), the PR-650's power-on window or the newer
// meters' remote mode, echo, faults on the bytes of each reply, and pacing. What a command
// means is the responder's business.

#include "skinspec/simulator/meter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>
#include <utility>

#include "framing.hpp"
#include "reply_faults.hpp"
#include "responder.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::simulator {

using namespace std::chrono_literals;
using drivers::Clock;
using Mode = SimulatedMeter::Mode;
using ServeEnd = SimulatedMeter::ServeEnd;

namespace {

constexpr auto kPoll = 20ms;  // how often serve() looks at `stop`
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

bool has(const std::vector<Fault>& faults, FaultKind kind) {
  return std::ranges::any_of(faults, [&](const Fault& f) { return f.kind == kind; });
}

std::optional<detail::FastLoss> fast_loss_of(const FaultPlan& plan) {
  for (const FaultSpec& spec : plan.specs())
    if (spec.fault.kind == FaultKind::fast_loss)
      return detail::FastLoss(std::chrono::milliseconds(static_cast<int>(spec.fault.amount)));
  return std::nullopt;
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
  bool newer;  // PHOTO and Q rather than the power-on window
  std::unique_ptr<detail::Responder> responder;
  std::unique_ptr<detail::Framer> framer;
  std::optional<detail::FastLoss> fast_loss;
  std::mt19937_64 rng;  // the bytes of garbage and bit flips, random lines

  mutable std::mutex mutex;  // everything below, and the responder
  Mode mode = Mode::boot;
  Clock::time_point powered_on = Clock::now();
  bool echo = false;
  std::string held_banner;  // the glue fault: sent in front of the next reply
  std::size_t commands = 0;
  std::vector<std::string> problems;

  Impl(MeterOptions o)
      : options(std::move(o)),
        newer(drivers::profile(options.model).caps.remote_keyword),
        framer(newer ? detail::make_remote_framer() : detail::make_line_framer()),
        fast_loss(fast_loss_of(options.faults)),
        rng(options.seed ^ 0x5eed),
        mode(power_on_mode()) {}

  void log(std::string_view text) const {
    if (options.log) options.log(text);
  }
  Mode power_on_mode() const { return newer ? Mode::local : Mode::boot; }
  Mode current_mode() const;  // with the mutex held
  std::optional<Outgoing> take_frame(const detail::Frame& frame);
  std::optional<Outgoing> take_line(std::string_view line);
  std::optional<Outgoing> take_photo();
  std::optional<Outgoing> take_quit();
  std::optional<Outgoing> answer(const detail::Command& command, std::vector<Fault>& faults);
  std::optional<Outgoing> take_unprompted();
  Outgoing outgoing(detail::Reply reply, const std::vector<Fault>& faults);
  std::optional<ServeEnd> transmit(drivers::Transport& link, const std::atomic<bool>& stop, const Outgoing& out);
  void act_on_unread(drivers::Transport& link, std::string_view unread);
  void trace(char byte, bool framed);
  std::string traced;  // the bytes of the command being received, for trace_bytes
};

namespace {
std::string escaped(std::string_view bytes) {
  std::string out;
  for (const char c : bytes) {
    if (c == '\r') out += "\\r";
    else if (c == '\n') out += "\\n";
    else if (c < 0x20 || c == 0x7f) out += fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
    else out += c;
  }
  return out;
}
}  // namespace

// One line per byte with the command so far ("received \"D11\""), so that a test can act
// between two bytes of a paced command.
void SimulatedMeter::Impl::trace(char byte, bool framed) {
  traced += byte;
  log(fmt::format("received \"{}\"", escaped(traced)));
  if (framed || byte == '\r' || byte == '\n') traced.clear();
}

Mode SimulatedMeter::Impl::current_mode() const {
  if (mode == Mode::boot && Clock::now() - powered_on > Millis(options.boot_window_s * 1000)) return Mode::local;
  return mode;
}

// What a frame makes the meter send, if anything.
std::optional<Outgoing> SimulatedMeter::Impl::take_frame(const detail::Frame& frame) {
  using Kind = detail::Frame::Kind;
  switch (frame.kind) {
    case Kind::overflow:
      log("input line too long for the meter's buffer: dropped");
      return std::nullopt;
    case Kind::photo:
      return take_photo();
    case Kind::quit:
      return take_quit();
    case Kind::line:
      break;
  }
  return take_line(frame.text);
}

std::optional<Outgoing> SimulatedMeter::Impl::take_line(std::string_view line) {
  const detail::Command command = newer ? detail::parse_remote_command(line) : detail::parse_command(line);
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
  if (has(faults, FaultKind::no_answer)) return std::nullopt;
  if (has(faults, FaultKind::reboot)) {
    mode = Mode::local;
    echo = false;
    held_banner.clear();
    responder->power_cycle();
    log(newer ? "rebooted: local mode, waiting for PHOTO" : "rebooted: local mode, silent until power-cycled");
    return std::nullopt;
  }
  return answer(command, faults);
}

// PHOTO enters remote mode and is answered with the banner, the first time only.
std::optional<Outgoing> SimulatedMeter::Impl::take_photo() {
  const detail::Command command = detail::parse_remote_command(drivers::pr6xx::kRemoteKeyword);
  std::lock_guard lock(mutex);
  ++commands;
  if (mode == Mode::remote) {
    log("PHOTO ignored: already in remote mode");
    responder->skipped(command);
    return std::nullopt;
  }
  std::vector<Fault> faults = options.faults.next(command.key);
  for (const auto& fault : faults) log(fmt::format("fault {} on 'PHOTO'", fault.to_string()));
  if (has(faults, FaultKind::no_answer)) return std::nullopt;
  mode = Mode::remote;
  log("command PHOTO: remote mode");
  auto out = answer(command, faults);
  if (out && has(faults, FaultKind::glue)) {
    held_banner = std::move(out->bytes);
    return std::nullopt;
  }
  return out;
}

// Q leaves remote mode, without a reply.
std::optional<Outgoing> SimulatedMeter::Impl::take_quit() {
  const detail::Command command = detail::parse_remote_command(drivers::pr6xx::kQuit);
  std::lock_guard lock(mutex);
  ++commands;
  std::vector<Fault> faults = options.faults.next(command.key);
  for (const auto& fault : faults) log(fmt::format("fault {} on 'Q'", fault.to_string()));
  if (has(faults, FaultKind::no_answer)) return std::nullopt;
  mode = Mode::local;
  held_banner.clear();
  log("command Q: remote mode left");
  return answer(command, faults);
}

// The responder's answer, through the faults that act on its bytes.
std::optional<Outgoing> SimulatedMeter::Impl::answer(const detail::Command& command, std::vector<Fault>& faults) {
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
  if (outcome.reply->echo) echo = *outcome.reply->echo;
  Outgoing out = outgoing(std::move(*outcome.reply), faults);
  if (!held_banner.empty() && !out.bytes.empty()) {
    log("the held banner goes out in front of this reply");
    out.bytes.insert(0, std::exchange(held_banner, {}));
  }
  return out;
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
      case FaultKind::fast_loss:
      case FaultKind::glue:
      case FaultKind::error:
      case FaultKind::busy:
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
  if (link.peer_closed()) return ServeEnd::closed;  // the host left while the meter was busy
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

// A host that went away while the meter measured or talked: what it had sent before is in the
// meter's input buffer all the same, so the meter acts on it (a Q leaves remote mode) and answers
// no one.
void SimulatedMeter::Impl::act_on_unread(drivers::Transport& link, std::string_view unread) {
  std::string bytes(unread);
  char buffer[512];
  while (auto n = link.read(buffer, sizeof buffer, drivers::deadline_in(kPoll))) {
    if (*n == 0) break;
    bytes.append(buffer, *n);
  }
  for (const char c : bytes) {
    bool remote = false;
    {
      std::lock_guard lock(mutex);
      remote = current_mode() == Mode::remote;
    }
    if (auto frame = framer->push(c, newer ? remote : true)) (void)take_frame(*frame);
  }
}

namespace {
// A recording speaks for the model it was recorded from.
MeterOptions for_source(MeterOptions options, const ReadingSource& source) {
  if (const auto* recording = std::get_if<Recording>(&source)) options.model = recording->header.model;
  return options;
}
}  // namespace

SimulatedMeter::SimulatedMeter(ReadingSource source, MeterOptions options)
    : impl_(std::make_unique<Impl>(for_source(std::move(options), source))) {
  if (auto* synthesis = std::get_if<Synthesis>(&source)) {
    impl_->responder = impl_->newer ? detail::make_remote_instrument(std::move(*synthesis), impl_->options)
                                    : detail::make_instrument(std::move(*synthesis), impl_->options);
  } else {
    impl_->responder = detail::make_replayer(std::move(std::get<Recording>(source)), impl_->options);
  }
}

SimulatedMeter::~SimulatedMeter() = default;

SimulatedMeter::ServeEnd SimulatedMeter::serve(drivers::Transport& link, const std::atomic<bool>& stop) {
  Impl& m = *impl_;
  if (auto out = m.take_unprompted())
    if (auto end = m.transmit(link, stop, *out)) return *end;
  char buffer[512];
  while (!stop) {
    auto n = link.read(buffer, sizeof buffer, drivers::deadline_in(kPoll));
    if (!n) {
      using Kind = drivers::TransportError::Kind;
      if (n.error().kind == Kind::timeout) continue;
      if (n.error().kind == Kind::interrupted) return ServeEnd::stopped;
      return ServeEnd::closed;
    }
    std::string_view received(buffer, *n);
    std::string survived;
    if (m.fast_loss) {
      survived = m.fast_loss->filter(received, Clock::now());
      if (survived.size() < received.size())
        m.log(fmt::format("fault fast-loss: {} of {} bytes lost", received.size() - survived.size(), received.size()));
      received = survived;
    }
    std::string echoed;
    for (std::size_t i = 0; i < received.size(); ++i) {
      const char c = received[i];
      bool remote = false;
      {
        std::lock_guard lock(m.mutex);
        remote = m.current_mode() == Mode::remote;
        if (m.echo && remote) echoed += c;
      }
      auto frame = m.framer->push(c, m.newer ? remote : true);
      if (m.options.trace_bytes) m.trace(c, frame.has_value());
      if (!frame) continue;
      // The echo of a command goes out before its reply.
      if (!echoed.empty() && !link.write(std::exchange(echoed, {}), drivers::deadline_in(kWriteTimeout)))
        return ServeEnd::closed;
      auto out = m.take_frame(*frame);
      if (!out) continue;
      if (auto end = m.transmit(link, stop, *out)) {
        if (*end == ServeEnd::closed) m.act_on_unread(link, received.substr(i + 1));
        return *end;
      }
      if (auto more = m.take_unprompted())
        if (auto end = m.transmit(link, stop, *more)) return *end;
    }
    if (const auto ignored = m.framer->take_ignored())
      m.log(fmt::format("{} bytes ignored outside remote mode", ignored));
    if (!echoed.empty() && !link.write(echoed, drivers::deadline_in(kWriteTimeout))) return ServeEnd::closed;
  }
  return ServeEnd::stopped;
}

void SimulatedMeter::power_cycle() {
  std::lock_guard lock(impl_->mutex);
  impl_->mode = impl_->power_on_mode();
  impl_->powered_on = Clock::now();
  impl_->echo = false;
  impl_->held_banner.clear();
  impl_->responder->power_cycle();
  impl_->log(impl_->newer ? "power-cycled: local mode" : "power-cycled: power-on window open");
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
