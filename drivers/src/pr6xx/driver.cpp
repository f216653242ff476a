#include "skinspec/drivers/pr6xx.hpp"

#include "common/remote_session.hpp"

namespace skinspec::drivers {

Pr6xx::Pr6xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options)
    : RemoteMeter(Family::pr6xx, model, std::move(transport), options) {}

// M5 measures and answers with the spectrum. A measurement that never answered is made once
// more; one whose reply came damaged did measure, so D5 reads the same measurement again.
std::expected<RemoteMeter::Spectrum, InstrumentError> Pr6xx::take_spectrum(int exposure_ms, int cycles) {
  const auto limit = measurement_time(exposure_ms, cycles);
  const std::string command = pr6xx::format_measure(5, options().style);
  bool remeasured = false;
  for (int attempt = 1; attempt <= 2; ++attempt) {
    const remote::Rule rule{pr6xx::ReplyShape::spectral, grid().points, limit, options().timing.idle,
                            whole_reply(grid().points),  false};
    auto reply = session().transact(command, rule);
    if (!reply) {
      if (reply.error().kind == InstrumentError::Kind::cancelled) measurement_pending(limit);
      return std::unexpected(reply.error());
    }
    if (reply->end == remote::ReplyEnd::silent) {
      remeasured = true;
      continue;
    }
    if (reply->end == remote::ReplyEnd::complete)
      if (auto report = pr6xx::parse_spectral(reply->bytes, grid()); report)
        return Spectrum{std::move(*report), reply->bytes, remeasured};
    auto again = read_spectrum(pr6xx::format_report(5, options().style), options().timing.reply, true);
    if (again) again->remeasured = remeasured;
    return again;
  }
  return std::unexpected(session().unanswered(command, {}));
}

}  // namespace skinspec::drivers
