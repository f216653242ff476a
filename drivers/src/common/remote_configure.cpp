// How a newer meter is set up for a measurement (docs/pr6xx-protocol.md, "The drivers"):
// options checked against the model's profile before a byte is sent, then each setup command
// sent only when it differs from what the meter holds on this connection.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "common/remote_session.hpp"
#include "skinspec/drivers/measure_settings.hpp"
#include "skinspec/drivers/remote_meter.hpp"

namespace skinspec::drivers {

namespace p6 = pr6xx;
using remote::Rule;

namespace {

constexpr int kBusy = 1;  // a PR-7xx still measuring

std::unexpected<InstrumentError> rejected(std::string message, int code = -1) {
  return std::unexpected(InstrumentError{InstrumentError::Kind::rejected, std::move(message), code, {}});
}

}  // namespace

int RemoteMeter::longest_exposure_ms(const MeasureOptions& options) const {
  return drivers::longest_exposure_ms(setting_limits(profile_.model), options.extended_sensitivity);
}

// Out-of-range options, and what the model does not have, are refused before a byte is sent,
// naming the model's range.
std::expected<void, InstrumentError> RemoteMeter::check(const MeasureOptions& options) const {
  const SettingLimits limits = setting_limits(profile_.model);
  if (const auto setting = refused_setting(limits, options))
    return rejected(refusal_message(limits, options, *setting));
  return {};
}

// A PR-7xx still measuring answers busy: the setup is sent again once it is done.
std::expected<void, InstrumentError> RemoteMeter::setup(std::optional<std::string>& last, const std::string& command,
                                                        std::string_view range) {
  if (last == command) return {};
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  auto status = session_->ask(command, rule, "setup reply", p6::parse_status);
  if (status && status->code == kBusy) {
    if (auto idle = wait_while_busy(command); !idle) return idle;
    status = session_->ask(command, rule, "setup reply", p6::parse_status);
  }
  if (!status) return std::unexpected(status.error());
  if (status->code != 0) {
    last.reset();
    return rejected(fmt::format("the {} refused '{}': {}{}", profile_.name, remote::printable(command),
                                p6::error_message(status->code), range),
                    status->code);
  }
  last = command;
  return {};
}

// Older firmware may not know a setup a newer one added. Where going without it changes nothing
// the reading depends on (`harmless`: it would set what the meter starts with, or only the
// photometric units, which are then the meter's), the driver says so once and sends it no more
// on this connection; otherwise the refusal stands.
bool RemoteMeter::do_without(const InstrumentError& error, bool& known, bool harmless, std::string_view command,
                             const Instead& instead) {
  if (error.kind != InstrumentError::Kind::rejected || error.quality_code != p6::kIllegalCommand || !harmless)
    return false;
  known = false;
  note_firmware(fmt::format("{}: the {} does not know '{}' ({}); {}", instead.code, profile_.name,
                            remote::printable(command), p6::error_message(p6::kIllegalCommand), instead.what));
  return true;
}

// SS, or SQ as the older manuals' syntax line spells it, once SS was not known.
std::expected<void, InstrumentError> RemoteMeter::setup_sync_mode(p6::SyncMode mode) {
  auto ok = setup(sync_mode_, p6::format_sync_mode(mode, options_.style, dialect_.sync));
  if (ok || dialect_.sync == SyncCommand::sq || ok.error().quality_code != p6::kIllegalCommand) return ok;
  dialect_.sync = SyncCommand::sq;
  note_firmware(
      fmt::format("sync-command: the {} does not know 'SS' ({}); sync is set with SQ, as its manual's "
                  "syntax line spells it",
                  profile_.name, p6::error_message(p6::kIllegalCommand)));
  return setup(sync_mode_, p6::format_sync_mode(mode, options_.style, dialect_.sync));
}

std::expected<void, InstrumentError> RemoteMeter::wait_while_busy(std::string_view command) {
  return std::unexpected(InstrumentError{
      InstrumentError::Kind::protocol,
      fmt::format("the {} answered '{}' with busy, which it does not do", profile_.name, remote::printable(command)),
      kBusy,
      {}});
}

// D117, read once per connection; a meter that refuses it lists none, and says why.
std::expected<void, InstrumentError> RemoteMeter::list_apertures() {
  if (apertures_) return {};
  const Rule rule{p6::ReplyShape::listing, 0, options_.timing.reply, options_.timing.idle, whole_reply(8), true};
  auto listed = session_->ask(p6::format_report(117, options_.style), rule, "aperture list", p6::parse_apertures);
  if (!listed) return std::unexpected(listed.error());
  unlisted_ =
      listed->status.code == 0 ? std::string() : fmt::format(" (D117: {})", p6::error_message(listed->status.code));
  apertures_ = listed->status.code == 0 ? listed->apertures : std::vector<p6::Aperture>{};
  return {};
}

std::expected<std::vector<std::string>, InstrumentError> RemoteMeter::apertures() {
  std::lock_guard lock(call_mutex_);
  session_->reset_cancel();
  if (!profile_.caps.aperture) return std::vector<std::string>{};
  if (!connected_)
    return std::unexpected(
        InstrumentError{InstrumentError::Kind::lost, fmt::format("the {} is not connected", profile_.name), -1, {}});
  if (auto listed = list_apertures(); !listed) return std::unexpected(listed.error());
  std::vector<std::string> names;
  for (const p6::Aperture& a : *apertures_) names.push_back(a.name);
  return names;
}

// The code D117 gives the aperture `name`.
std::expected<int, InstrumentError> RemoteMeter::aperture_code(const std::string& name) {
  if (auto listed = list_apertures(); !listed) return std::unexpected(listed.error());
  const auto found =
      std::ranges::find_if(*apertures_, [&](const p6::Aperture& a) { return same_aperture(a.name, name); });
  if (found != apertures_->end()) return found->code;
  std::vector<std::string> names;
  for (const p6::Aperture& a : *apertures_) names.push_back(fmt::format("'{}'", a.name));
  if (names.empty()) return rejected(fmt::format("aperture '{}': the {} lists none{}", name, profile_.name, unlisted_));
  return rejected(fmt::format("aperture '{}': the {} lists {}", name, profile_.name, fmt::join(names, ", ")));
}

// Units, sensitivity, exposure, averages, aperture and sync, each sent only when it differs from
// what the meter holds. Sensitivity comes before the exposure, whose range it sets. Returns how
// the sync was set, for the reading.
std::expected<std::string, InstrumentError> RemoteMeter::configure(const MeasureOptions& options, int exposure_ms,
                                                                   bool sync_on) {
  const p6::CommandStyle& style = options_.style;
  if (dialect_.units) {
    const std::string units = p6::format_units(options.si_units, style);
    if (auto ok = setup(units_, units); !ok && !do_without(ok.error(), dialect_.units, true, units,
                                                           {"no-units", "luminance is in the units set on the meter"}))
      return std::unexpected(ok.error());
  }
  if (profile_.caps.sensitivity && dialect_.sensitivity) {
    const auto before = sensitivity_;
    const std::string sensitivity = p6::format_sensitivity(options.extended_sensitivity, style);
    if (auto ok = setup(sensitivity_, sensitivity);
        !ok && !do_without(ok.error(), dialect_.sensitivity, !options.extended_sensitivity, sensitivity,
                           {"no-sensitivity", "the meter measures at the standard sensitivity it starts with"}))
      return std::unexpected(ok.error());
    if (sensitivity_ != before) exposure_.reset();  // the meter shortens an exposure the new range lacks
  }
  const std::string range =
      fmt::format("; the {} takes {}-{} ms", profile_.name, profile_.exposure.min_ms, longest_exposure_ms(options));
  if (auto ok = setup(exposure_, p6::format_exposure(exposure_ms, style), range); !ok)
    return std::unexpected(ok.error());
  if (dialect_.averages) {
    const std::string averages = p6::format_averages(options.averages, style);
    if (auto ok = setup(averages_, averages);
        !ok && !do_without(ok.error(), dialect_.averages, options.averages == 1, averages,
                           {"no-averages", "the meter measures once, as it starts"}))
      return std::unexpected(ok.error());
  }
  if (!options.aperture.empty()) {
    auto code = aperture_code(options.aperture);
    if (!code) return std::unexpected(code.error());
    if (auto ok = setup(aperture_, p6::format_aperture(*code, style)); !ok) return std::unexpected(ok.error());
  }
  return configure_sync(options, sync_on);
}

// Automatic sync measures the flicker first (F) and syncs when there is one; a user frequency
// is SS3 with SK. `sync_on` false (asked for, or after the meter could not sync): SS0.
std::expected<std::string, InstrumentError> RemoteMeter::configure_sync(const MeasureOptions& options, bool sync_on) {
  const p6::CommandStyle& style = options_.style;
  auto mode_is = [&](p6::SyncMode mode) { return setup_sync_mode(mode); };
  if (sync_on && options.sync == MeasureOptions::Sync::frequency) {
    const int hz = static_cast<int>(options.sync_hz);
    if (auto ok = mode_is(p6::SyncMode::user); !ok) return std::unexpected(ok.error());
    if (auto ok = setup(sync_frequency_, p6::format_sync_frequency(hz, style)); !ok) return std::unexpected(ok.error());
    return fmt::format("{} Hz (user)", hz);
  }
  std::string described = "off";
  p6::SyncMode mode = p6::SyncMode::none;
  if (sync_on) {
    const Rule rule{p6::ReplyShape::line, 0, options_.timing.flicker, options_.timing.idle, whole_reply(0), true};
    auto flicker = session_->ask(p6::format_flicker(style), rule, "flicker reply", p6::parse_flicker);
    if (!flicker) return std::unexpected(flicker.error());
    if (flicker->status.code == 0 && flicker->hz) {
      mode = p6::SyncMode::automatic;
      described = fmt::format("automatic ({:.2f} Hz)", *flicker->hz);
    } else {
      described = "off (no flicker found)";
    }
  }
  if (auto ok = mode_is(mode); !ok) return std::unexpected(ok.error());
  return described;
}

}  // namespace skinspec::drivers
