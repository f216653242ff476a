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

// A cancelled measurement is aborted on the meter, which otherwise keeps measuring for up to
// minutes and ignores the next commands. The meter stays in remote mode.
std::expected<void, InstrumentError> Pr7xx::abort_measurement() {
  const remote::Rule rule{pr6xx::ReplyShape::line, 0,    options().timing.reply, options().timing.idle,
                          whole_reply(0),          false};
  (void)session().transact_despite_cancel(p7::format_abort(options().style), rule);
  return cancelled();
}

// T starts the measurement, P follows it (every poll_interval, until the measurement's time is
// up), V tells its outcome and D5 reads its spectrum. V comes before D5 because a failed
// measurement may leave the spectrum of the one before in the meter's buffer.
std::expected<RemoteMeter::Spectrum, InstrumentError> Pr7xx::take_spectrum(int exposure_ms, int cycles) {
  const remote::Rule rule{pr6xx::ReplyShape::line, 0,    options().timing.reply, options().timing.idle,
                          whole_reply(0),          false};
  auto trigger = session().transact(p7::format_trigger(options().style), rule);
  if (!trigger) {
    if (trigger.error().kind == InstrumentError::Kind::cancelled) return std::unexpected(abort_measurement().error());
    return std::unexpected(trigger.error());
  }
  // T's own reply is undocumented: nothing, or a status; only a refusal matters.
  if (trigger->end == remote::ReplyEnd::complete)
    if (auto status = p7::parse_trigger(trigger->bytes); status && *status && (*status)->code < 0)
      return failed_with((*status)->code);

  const auto limit = measurement_time(exposure_ms, cycles);
  const Deadline until = deadline_in(limit);
  const std::string poll = p7::format_poll(options().style);
  int lost_in_a_row = 0;
  std::optional<int> code;
  while (!code) {
    if (!session().pause(options().timing.poll_interval)) return std::unexpected(abort_measurement().error());
    if (Clock::now() > until)
      return std::unexpected(InstrumentError{
          InstrumentError::Kind::lost,
          fmt::format("the {} did not finish its measurement within {} ms", profile().name, limit.count()),
          -1,
          {}});
    auto reply = session().transact(poll, rule);
    if (!reply) {
      if (reply.error().kind == InstrumentError::Kind::cancelled) return std::unexpected(abort_measurement().error());
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
    if (parsed->state == p7::PollReply::State::done) code = parsed->code.value_or(0);
  }
  if (*code < 0) return failed_with(*code);
  auto outcome = session().ask(p7::format_last_error(options().style),
                               remote::Rule{rule.shape, 0, rule.first_byte, rule.idle, rule.whole, true}, "last error",
                               p7::parse_last_error);
  if (!outcome) return std::unexpected(outcome.error());
  if (outcome->code != 0) return failed_with(outcome->code);
  return read_spectrum(pr6xx::format_report(5, options().style), options().timing.reply, true);
}

}  // namespace skinspec::drivers
