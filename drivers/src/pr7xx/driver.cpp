#include "skinspec/drivers/pr7xx.hpp"

#include <fmt/format.h>

#include "common/remote_session.hpp"
#include "skinspec/drivers/pr7xx_protocol.hpp"

namespace skinspec::drivers {

namespace p7 = pr7xx;

namespace {

std::unexpected<InstrumentError> cancelled() {
  return std::unexpected(InstrumentError{InstrumentError::Kind::cancelled, "cancelled", -1, {}});
}

}  // namespace

Pr7xx::Pr7xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options)
    : RemoteMeter(Family::pr7xx, model, std::move(transport), options) {}

// T, P, A and V change the meter's state: a lost reply is not asked for again.
remote::Rule Pr7xx::line_rule() const {
  return {pr6xx::ReplyShape::line, 0, options().timing.reply, options().timing.idle, whole_reply(0), false};
}

// A cancelled measurement is aborted on the meter, which otherwise keeps measuring for up to
// minutes and ignores the next commands. The meter stays in remote mode. A firmware without A
// measures on: its reply is drained before the next measurement, and M5 is used from now on.
std::expected<void, InstrumentError> Pr7xx::abort_measurement(std::chrono::milliseconds limit) {
  const std::string abort = p7::format_abort(options().style);
  auto reply = session().transact_despite_cancel(abort, line_rule());
  if (reply && reply->end == remote::ReplyEnd::complete)
    if (auto parsed = p7::parse_abort(reply->bytes); parsed && parsed->code == pr6xx::kIllegalCommand) {
      stop_triggering(abort);
      measurement_pending(limit);
    }
  return cancelled();
}

// P every poll_interval while the meter answers busy, until `limit`: the measurement's code
// (0 or negative; illegal command when the meter does not know P). cancel() aborts the
// measurement.
std::expected<int, InstrumentError> Pr7xx::poll_until_done(std::chrono::milliseconds limit) {
  const remote::Rule rule = line_rule();
  const Deadline until = deadline_in(limit);
  const std::string poll = p7::format_poll(options().style);
  int lost_in_a_row = 0;
  for (;;) {
    if (!session().pause(options().timing.poll_interval)) return std::unexpected(abort_measurement(limit).error());
    if (Clock::now() > until)
      return std::unexpected(InstrumentError{
          InstrumentError::Kind::lost,
          fmt::format("the {} did not finish its measurement within {} ms", profile().name, limit.count()),
          -1,
          {}});
    auto reply = session().transact(poll, rule);
    if (!reply) {
      if (reply.error().kind == InstrumentError::Kind::cancelled)
        return std::unexpected(abort_measurement(limit).error());
      return std::unexpected(reply.error());
    }
    auto parsed = reply->end == remote::ReplyEnd::complete
                      ? p7::parse_poll(reply->bytes)
                      : std::expected<p7::PollReply, ProtocolError>(std::unexpected(ProtocolError{}));
    if (!parsed) {
      if (++lost_in_a_row >= 2) return std::unexpected(session().unanswered(poll, *reply));
      continue;
    }
    lost_in_a_row = 0;
    if (parsed->state == p7::PollReply::State::done) return parsed->code.value_or(0);
  }
}

// A measurement still running (one whose abort was lost, or another program's) makes the meter
// answer busy: it is followed to its end, and its outcome is not ours.
std::expected<void, InstrumentError> Pr7xx::wait_while_busy(std::string_view /*command*/) {
  auto done = poll_until_done(measurement_time(0, 1));
  if (!done) return std::unexpected(done.error());
  return {};
}

// T starts the measurement (again, after waiting, if the meter was busy with another), P
// follows it until its time is up, V tells its outcome and D5 reads its spectrum. V comes
// before D5 because a failed measurement may leave the spectrum of the one before in the
// meter's buffer. A firmware that does not know T or P (illegal command) is measured with M5,
// on this connection from then on.
std::expected<RemoteMeter::Spectrum, InstrumentError> Pr7xx::take_spectrum(int exposure_ms, int cycles) {
  if (!dialect().trigger) return measure_with_m5(exposure_ms, cycles);
  const std::string trigger_command = p7::format_trigger(options().style);
  auto triggered = trigger(trigger_command, measurement_time(exposure_ms, cycles));
  if (!triggered) return std::unexpected(triggered.error());
  if (*triggered == Trigger::unknown) {
    stop_triggering(trigger_command);
    return measure_with_m5(exposure_ms, cycles);
  }
  if (*triggered == Trigger::failed) return failed_with(last_trigger_code_);
  auto code = poll_until_done(measurement_time(exposure_ms, cycles));
  if (!code) return std::unexpected(code.error());
  if (*code == pr6xx::kIllegalCommand) {
    stop_triggering(p7::format_poll(options().style));
    // The measurement T started ends before the meter takes M5.
    return measure_with_m5(exposure_ms, cycles);
  }
  if (*code < 0) return failed_with(*code);
  if (dialect().last_error) {
    const remote::Rule rule = line_rule();
    auto outcome = session().ask(p7::format_last_error(options().style),
                                 remote::Rule{rule.shape, 0, rule.first_byte, rule.idle, rule.whole, true},
                                 "last error", p7::parse_last_error);
    if (!outcome) return std::unexpected(outcome.error());
    if (outcome->code == pr6xx::kIllegalCommand) without_last_error();
    else if (outcome->code != 0) return failed_with(outcome->code);
  }
  return read_spectrum(pr6xx::format_report(5, options().style), options().timing.reply, true);
}

// T, sent again once after waiting if the meter was busy with another measurement. Its own
// reply is undocumented: nothing, or a status; only a refusal, illegal command or busy matters.
std::expected<Pr7xx::Trigger, InstrumentError> Pr7xx::trigger(const std::string& command,
                                                              std::chrono::milliseconds limit) {
  for (int attempt = 1;; ++attempt) {
    auto reply = session().transact(command, line_rule());
    if (!reply) {
      if (reply.error().kind == InstrumentError::Kind::cancelled)
        return std::unexpected(abort_measurement(limit).error());
      return std::unexpected(reply.error());
    }
    if (reply->end != remote::ReplyEnd::complete) return Trigger::started;
    auto status = p7::parse_trigger(reply->bytes);
    if (!status || !*status || (*status)->code == 0) return Trigger::started;
    last_trigger_code_ = (*status)->code;
    if (last_trigger_code_ == pr6xx::kIllegalCommand) return Trigger::unknown;
    if (last_trigger_code_ < 0) return Trigger::failed;
    if (attempt == 2)
      return std::unexpected(InstrumentError{
          InstrumentError::Kind::protocol,
          fmt::format("the {} stayed busy after the measurement it was making had ended", profile().name),
          last_trigger_code_, reply->bytes});
    if (auto idle = wait_while_busy(command); !idle) return std::unexpected(idle.error());
  }
}

}  // namespace skinspec::drivers
