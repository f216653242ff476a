// Replay: each command is answered with the bytes recorded for it, in order.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "reply_faults.hpp"
#include "responder.hpp"

namespace skinspec::simulator::detail {

namespace {

// A command as the meter reads it: without line ends, in upper case.
std::string normalised(std::string_view tx) {
  std::string out;
  for (const char c : tx)
    if (c != '\r' && c != '\n') out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string printable(std::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '\r') {
      out += "\\r";
    } else if (c == '\n') {
      out += "\\n";
    } else if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) {
      out += fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
    } else {
      out += c;
    }
  }
  return out;
}

Reply reply_of(std::string bytes, const Exchange& exchange) {
  Reply reply;
  reply.bytes = std::move(bytes);
  reply.delay_ms = exchange.delay_ms;
  reply.byte_interval_ms = exchange.byte_interval_ms;
  return reply;
}

class Replayer final : public Responder {
 public:
  Replayer(Recording recording, const MeterOptions& options)
      : recording_(std::move(recording)), used_(recording_.exchanges.size(), false), order_(options.replay_order) {}

  Outcome respond(const Command& command, std::vector<Fault>& faults) override;
  std::optional<Reply> unprompted() override;
  void skipped(const Command& command) override;
  void power_cycle() override { forced_quality_.reset(); }
  std::size_t measurements() const override { return measurements_; }

 private:
  std::optional<std::size_t> find(const Command& command, std::string& problem) const;

  Recording recording_;
  std::vector<bool> used_;
  MeterOptions::ReplayOrder order_;
  std::optional<int> forced_quality_;  // a quality fault on the last M: its reports carry the code
  std::size_t measurements_ = 0;
};

// The exchange that answers `command`, or a description of why there is none.
std::optional<std::size_t> Replayer::find(const Command& command, std::string& problem) const {
  const auto& exchanges = recording_.exchanges;
  if (order_ == MeterOptions::ReplayOrder::in_order) {
    // Unprompted output (no tx) is sent by itself, not in answer to a command.
    std::size_t i = 0;
    while (i < exchanges.size() && (used_[i] || exchanges[i].tx.empty())) ++i;
    if (i >= exchanges.size()) {
      problem = fmt::format("replay: received '{}' after the last of {} recorded exchanges: no answer", command.text,
                            exchanges.size());
      return std::nullopt;
    }
    if (normalised(exchanges[i].tx) != command.text) {
      problem = fmt::format("replay mismatch at exchange {} of {}: expected '{}', received '{}': no answer", i + 1,
                            exchanges.size(), printable(exchanges[i].tx), command.text);
      return std::nullopt;
    }
    return i;
  }
  for (std::size_t i = 0; i < exchanges.size(); ++i)
    if (!used_[i] && !exchanges[i].tx.empty() && normalised(exchanges[i].tx) == command.text) return i;
  problem = fmt::format("replay: no recorded exchange left for '{}': no answer", command.text);
  return std::nullopt;
}

Outcome Replayer::respond(const Command& command, std::vector<Fault>& faults) {
  Outcome out;
  std::string problem;
  const auto index = find(command, problem);
  if (!index) {
    out.problems.push_back(std::move(problem));
    return out;
  }
  used_[*index] = true;
  const Exchange& exchange = recording_.exchanges[*index];
  faults.insert(faults.end(), exchange.faults.begin(), exchange.faults.end());

  // A quality fault on a measurement marks the reports that follow it, as the meter would.
  if (command.letter == 'M') {
    ++measurements_;
    forced_quality_.reset();
    std::erase_if(faults, [&](const Fault& fault) {
      if (fault.kind != FaultKind::quality && fault.kind != FaultKind::stale) return false;
      forced_quality_ = fault.amount < 0 ? 18 : static_cast<int>(fault.amount);
      return true;
    });
  }
  std::string bytes = exchange.rx;
  if (forced_quality_ && (command.letter == 'D' || command.letter == 'M'))
    bytes = with_quality(std::move(bytes), *forced_quality_);
  out.notes.push_back(fmt::format("replay: exchange {} answers '{}'", *index + 1, command.text));
  if (bytes.empty()) return out;  // recorded silence
  out.reply = reply_of(std::move(bytes), exchange);
  return out;
}

// The recorded silence after a command the meter ignored is used up, so that the exchanges
// after it still line up.
void Replayer::skipped(const Command& command) {
  std::string problem;
  const auto index = find(command, problem);
  if (index && recording_.exchanges[*index].rx.empty()) used_[*index] = true;
}

std::optional<Reply> Replayer::unprompted() {
  const auto next = static_cast<std::size_t>(std::ranges::find(used_, false) - used_.begin());
  if (next >= recording_.exchanges.size() || !recording_.exchanges[next].tx.empty()) return std::nullopt;
  used_[next] = true;
  const Exchange& exchange = recording_.exchanges[next];
  return reply_of(exchange.rx, exchange);
}

}  // namespace

std::unique_ptr<Responder> make_replayer(Recording recording, const MeterOptions& options) {
  return std::make_unique<Replayer>(std::move(recording), options);
}

}  // namespace skinspec::simulator::detail
