#include "identify/probe.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "common/text.hpp"
#include "identify/borrowed_transport.hpp"
#include "identify/family_driver.hpp"

namespace skinspec::drivers::identify {

namespace p6 = pr6xx;

namespace {

constexpr std::string_view kNewerMeters = "PR-655/670/680 or PR-7xx";

std::unexpected<InstrumentError> fail(InstrumentError::Kind kind, std::string message, std::string raw = {}) {
  return std::unexpected(InstrumentError{kind, std::move(message), -1, std::move(raw)});
}

// The newer meters' pace between bytes, unless the options set one: the slowest any needs.
std::chrono::milliseconds newer_meter_pacing(const RemoteOptions& options) {
  if (options.pacing) return *options.pacing;
  std::chrono::milliseconds slowest{0};
  for (const MeterProfile& row : all_profiles())
    if (row.caps.remote_keyword) slowest = std::max(slowest, row.pacing);
  return slowest;
}

// "pr655, pr670, ...": what --model can name for a newer meter.
std::string newer_model_ids() {
  std::string ids;
  for (const MeterProfile& row : all_profiles())
    if (row.caps.remote_keyword) ids += fmt::format("{}{}", ids.empty() ? "" : ", ", row.id);
  return ids;
}

bool one_family(const ModelMatch& match) {
  const Family family = profile(match.candidates.front()).family;
  return std::ranges::all_of(match.candidates, [&](Model m) { return profile(m).family == family; });
}

}  // namespace

Probe::Probe(Transport& link, const InstrumentOptions& options) : link_(link), options_(options) {}

Probe::~Probe() = default;

void Probe::cancel() {
  std::lock_guard lock(mutex_);
  cancelled_ = true;
  if (pr650_) pr650_->cancel();
  if (session_) session_->cancel();
  link_.interrupt();
}

bool Probe::cancelled() const {
  std::lock_guard lock(mutex_);
  return cancelled_;
}

std::uint64_t Probe::replies() const {
  std::lock_guard lock(mutex_);
  return (pr650_ ? pr650_->replies_received() : 0) + (session_ ? session_->replies() : 0);
}

std::expected<Found, InstrumentError> Probe::take_pr650() {
  std::lock_guard lock(mutex_);
  return Found{std::move(pr650_), false};
}

std::expected<Found, InstrumentError> Probe::run() {
  const auto cancelled_error = [] { return fail(InstrumentError::Kind::cancelled, "cancelled"); };
  // A PR-650 inside its power-on window answers the first b3 (the only contact it accepts).
  DriverOptions first = options_.pr650;
  first.contact_attempts = 1;
  {
    std::lock_guard lock(mutex_);
    if (cancelled_) return cancelled_error();
    pr650_ = std::make_unique<Pr650>(std::make_unique<BorrowedTransport>(link_), first);
  }
  auto contact = pr650_->connect();
  if (cancelled()) return cancelled_error();
  if (contact) return take_pr650();
  switch (contact.error().kind) {
    case InstrumentError::Kind::identification:  // a newer meter left in remote mode: Q resets it
      break;
    case InstrumentError::Kind::no_contact:
      if (contact.error().raw_reply.empty()) break;
      return fail(InstrumentError::Kind::identification,
                  fmt::format("the device on {} answered 'b3' with {}, which no Photo Research meter sends: not a "
                              "Photo Research meter?",
                              link_.describe(), detail::quoted(contact.error().raw_reply)),
                  contact.error().raw_reply);
    default:
      return std::unexpected(contact.error());
  }
  auto newer = find_newer_meter();
  if (newer || newer.error().kind != InstrumentError::Kind::no_contact) return newer;
  // A PR-650 switched on while the newer meters were asked for.
  if (const int remaining = options_.pr650.contact_attempts - 1; remaining > 0) {
    auto late = pr650_->contact(remaining, true);
    if (cancelled()) return cancelled_error();
    if (late) return take_pr650();
    if (late.error().kind != InstrumentError::Kind::no_contact) return std::unexpected(late.error());
  }
  return std::unexpected(silent_everywhere());
}

// Q and PHOTO, then D111 for the model; the driver of its family takes the meter over in
// remote mode.
std::expected<Found, InstrumentError> Probe::find_newer_meter() {
  {
    std::lock_guard lock(mutex_);
    if (cancelled_) return fail(InstrumentError::Kind::cancelled, "cancelled");
    session_ = std::make_unique<remote::Session>(link_, kNewerMeters, newer_meter_pacing(options_.remote),
                                                 options_.remote.timing, options_.remote.style);
  }
  auto glued = session_->enter_remote();
  if (!glued) return std::unexpected(glued.error());
  auto choice = choose_model(*session_);
  if (!choice) {
    session_->quit();  // the meter's screen would stay locked
    return std::unexpected(choice.error());
  }
  auto driver = make_remote_meter(choice->model, std::make_unique<BorrowedTransport>(link_), options_.remote);
  driver->adopt_remote_mode(*glued);
  return Found{std::move(driver), choice->unresolved};
}

// The model D111 names; D120's grid decides between the models of a '/'-list (PR-730/735).
std::expected<Probe::Choice, InstrumentError> Probe::choose_model(remote::Session& session) {
  const RemoteTiming& timing = options_.remote.timing;
  const remote::Rule rule{p6::ReplyShape::line, 0, timing.reply, timing.idle, remote::whole_reply(timing, 0), true};
  auto d111 = session.ask(p6::format_report(111, options_.remote.style), rule, "model name", p6::parse_text_report);
  if (!d111) return std::unexpected(d111.error());
  if (d111->status.code != 0)
    return fail(InstrumentError::Kind::identification,
                fmt::format("the meter on {} does not report its model (D111: {}); give --model with its model ({})",
                            link_.describe(), p6::error_message(d111->status.code), newer_model_ids()));
  const ModelMatch match = match_reported_model(d111->text);
  if (match.candidates.empty())
    return fail(InstrumentError::Kind::identification,
                fmt::format("the meter reports '{}', which skinspec does not know; give --model with the closest "
                            "model ({}) to measure it as that family",
                            d111->text, newer_model_ids()));
  if (match.candidates.size() == 1) return Choice{match.candidates.front(), false};
  auto d120 = session.ask(p6::format_report(120, options_.remote.style), rule, "hardware configuration",
                          p6::parse_hardware_configuration);
  if (!d120) return std::unexpected(d120.error());
  if (d120->status.code == 0)
    if (auto model = resolve_model(match, d120->grid)) return Choice{*model, false};
  // No model's grid fits: the family they share measures on whatever grid D120 gives.
  if (one_family(match)) return Choice{match.candidates.front(), true};
  return fail(InstrumentError::Kind::identification,
              fmt::format("the meter reports '{}', which names models of different families; give --model with its "
                          "model",
                          d111->text));
}

InstrumentError Probe::silent_everywhere() const {
  return {InstrumentError::Kind::no_contact,
          fmt::format("no Photo Research meter answered on {}: neither a PR-650 (to 'b3', {} times) nor a {} (to "
                      "PHOTO, twice). A PR-650 accepts remote control only within about 5 s of being switched on: "
                      "switch it off and on, and connect at once (with the cable's switch at 'ctrlr'). A "
                      "PR-655/670/7xx needs Power Saving off, the USB cable, and no other program holding the port; "
                      "if it still refuses, switch it off and on",
                      link_.describe(), std::max(1, options_.pr650.contact_attempts), kNewerMeters),
          -1,
          {}};
}

}  // namespace skinspec::drivers::identify
