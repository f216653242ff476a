// The instrument's connection: connecting and identifying, keeping it connected in the
// background, following USB hot-plug, and what its state is (connection_keeper.hpp).

#include "connection_keeper.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

#include "identity_json.hpp"
#include "store_records.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;
using SteadyClock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {

using Kind = drivers::InstrumentError::Kind;

// Failures that leave the link unusable, so that the next use starts again from first contact.
bool is_link_failure(Kind kind) {
  return kind == Kind::lost || kind == Kind::no_contact || kind == Kind::transport || kind == Kind::protocol;
}

// The worker does not announce the end of a job; while one runs the connector looks again
// this often.
constexpr milliseconds kBusyRecheck{250};
// How often an idle connected link is looked at for a hang-up its transport can see (a TCP
// peer that closed): a look costs no bytes on the wire, so it is much more frequent than the
// check that asks the meter.
constexpr milliseconds kHangupLook{100};

}  // namespace

ConnectionKeeper::ConnectionKeeper(std::string device, drivers::ModelChoice model, store::Store& db,
                                   std::function<bool()> jobs_waiting)
    : device_(std::move(device)), model_(model), db_(db), jobs_waiting_(std::move(jobs_waiting)) {}

ConnectionKeeper::~ConnectionKeeper() {
  stop();
  release_meter();
}

void ConnectionKeeper::stop() {
  std::lock_guard lock(mutex_);
  stopping_ = true;
  if (meter_) meter_->cancel();
  wake_.notify_all();
}

// The newer meters stay in remote mode, their keys locked, until they are sent Q: the meter is
// disconnected here, once nothing else can use it, rather than whenever its last owner lets go.
void ConnectionKeeper::release_meter() {
  if (connector_.joinable()) connector_.join();  // it ends at stopping_; a connection under way was cancelled
  std::shared_ptr<drivers::Instrument> meter;
  {
    std::lock_guard lock(mutex_);
    meter = std::exchange(meter_, nullptr);
  }
  if (!meter) return;
  const auto wire = wire_.hold();
  meter->disconnect();
  spdlog::info("event=instrument_disconnected device=\"{}\"", device_);
}

MeterSettings ConnectionKeeper::settings() const {
  std::lock_guard lock(mutex_);
  return known_settings();
}

MeterSettings ConnectionKeeper::known_settings() const {
  std::optional<drivers::Model> known = model_.forced;
  if (identity_ && identity_->model) known = identity_->model;
  return {drivers::setting_limits(known), apertures_};
}

std::shared_ptr<drivers::Instrument> ConnectionKeeper::begin_measuring() {
  std::lock_guard lock(mutex_);
  if (meter_) state_ = api::InstrumentState::measuring;
  return meter_;
}

void ConnectionKeeper::end_measuring() {
  std::lock_guard lock(mutex_);
  if (state_ == api::InstrumentState::measuring)
    state_ = meter_ ? api::InstrumentState::connected : api::InstrumentState::disconnected;
}

void ConnectionKeeper::interrupt() {
  std::lock_guard lock(mutex_);
  if (meter_) meter_->cancel();
}

void ConnectionKeeper::note_firmware_warnings(const std::vector<std::string>& warnings) {
  std::lock_guard lock(mutex_);
  if (!identity_) return;
  for (const auto& warning : warnings) {
    if (std::ranges::find(identity_->warnings, warning) != identity_->warnings.end()) continue;
    identity_->warnings.push_back(warning);
    spdlog::warn("event=instrument_firmware serial={} warning=\"{}\"", identity_->serial_number, warning);
  }
}

ConnectionKeeper::MeterOfRecord ConnectionKeeper::meter_of_record() const {
  std::lock_guard lock(mutex_);
  MeterOfRecord out;
  if (identity_) out.family = identity_->family;
  out.instrument_id = instrument_id_;
  return out;
}

json ConnectionKeeper::status() const {
  std::lock_guard lock(mutex_);
  json next_attempt_in_ms = nullptr;
  if (!meter_ && next_attempt_ && state_ != api::InstrumentState::connecting)
    next_attempt_in_ms =
        std::max<long long>(0, std::chrono::duration_cast<milliseconds>(*next_attempt_ - SteadyClock::now()).count());
  json status = {{"device", device_},
                 {"port", port_.empty() ? json(nullptr) : json(port_)},
                 {"state", std::string(api::to_string(state_.value()))},
                 {"since", api::api_time(to_store_time(state_.since()))},
                 {"last_error", last_error_.empty() ? json(nullptr) : json(last_error_)},
                 {"attempts", failed_attempts_},
                 {"next_attempt_in_ms", next_attempt_in_ms},
                 {"capabilities", capabilities_json(known_settings())}};
  // Who the meter said it was when last reached: kept while it is lost, as its serial number
  // tells which meter to look for.
  status.update(identity_ ? drivers::identity_json(*identity_) : drivers::no_identity_json());
  return status;
}

std::string ConnectionKeeper::meter_on_port() const {
  std::string name = "meter";
  if (identity_ && identity_->model) name = drivers::profile(*identity_->model).name;
  else if (identity_ && !identity_->reported_model.empty()) name = identity_->reported_model;
  return fmt::format("the {} on {}", name, port_);
}

void ConnectionKeeper::note_instrument_error(const drivers::InstrumentError& e) {
  std::lock_guard lock(mutex_);
  last_error_ = describe(e);
  if (is_link_failure(e.kind) && meter_) lose_meter(last_error_);
  state_ = meter_ ? api::InstrumentState::connected : unreachable_state();
  wake_.notify_all();
}

// The meter cannot be used any more: start again from first contact, the first attempt at once.
void ConnectionKeeper::lose_meter(const std::string& error) {
  last_error_ = error;
  spdlog::warn("event=instrument_lost device=\"{}\" error=\"{}\"", device_, last_error_);
  meter_.reset();
  state_ = api::InstrumentState::lost;
  failed_attempts_ = 0;
  next_attempt_ = SteadyClock::now();
  wake_.notify_all();
}

std::optional<drivers::InstrumentError> ConnectionKeeper::ensure_connected() {
  const auto wire = wire_.hold();
  return connect_holding_wire();
}

std::optional<drivers::InstrumentError> ConnectionKeeper::connect_holding_wire() {
  {
    std::lock_guard lock(mutex_);
    if (meter_ && meter_->connected()) {
      if (!meter_->link_closed()) return std::nullopt;
      lose_meter(fmt::format("lost: the link to {} was closed", meter_on_port()));
    }
    if (stopping_) return drivers::InstrumentError{Kind::cancelled, "the service is stopping", -1, {}};
    state_ = api::InstrumentState::connecting;
  }
  // Looked up on every attempt: an adapter may come back under another tty name.
  auto resolved = link_.resolver(device_);
  if (!resolved) {
    const drivers::InstrumentError error{Kind::transport, resolved.error(), -1, {}};
    note_connect_failure(error, {});
    return error;
  }
  const std::string port = resolved->uri.to_string();
  auto transport = drivers::make_transport(resolved->uri);
  if (!transport) {
    const drivers::InstrumentError error{Kind::transport, transport.error(), -1, {}};
    note_connect_failure(error, port);
    return error;
  }
  drivers::ModelChoice choice = model_;
  {
    std::lock_guard lock(mutex_);
    if (!choice.forced) choice.forced = expected_model_;
  }
  std::shared_ptr<drivers::Instrument> meter =
      drivers::make_instrument(std::move(*transport), choice, drivers::instrument_options_for(resolved->uri));
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return drivers::InstrumentError{Kind::cancelled, "the service is stopping", -1, {}};
    port_ = port;
    meter_ = meter;  // visible to cancel() and stop() while connecting
  }
  if (auto contact = meter->connect(); !contact) {
    note_connect_failure(contact.error(), port);
    return contact.error();
  }
  auto identity = meter->identify();
  if (!identity) {
    note_connect_failure(identity.error(), port);
    return identity.error();
  }
  // Read now, so that a job asking for one the meter does not list is refused when posted.
  auto apertures = meter->apertures();
  if (!apertures) {
    note_connect_failure(apertures.error(), port);
    return apertures.error();
  }
  note_connected(meter, *resolved, *identity, std::move(*apertures));
  return std::nullopt;
}

void ConnectionKeeper::note_connect_failure(const drivers::InstrumentError& error, const std::string& port) {
  std::lock_guard lock(mutex_);
  meter_.reset();
  expected_model_.reset();
  port_ = port;
  ++failed_attempts_;
  last_error_ = describe(error);
  state_ = unreachable_state();
  const auto delay = backoff_delay(link_.backoff, failed_attempts_);
  next_attempt_ = SteadyClock::now() + delay;
  spdlog::info("event=instrument_unreachable device=\"{}\" attempts={} next_attempt_in_ms={} error=\"{}\"", device_,
               failed_attempts_, delay.count(), last_error_);
  wake_.notify_all();
}

void ConnectionKeeper::note_connected(const std::shared_ptr<drivers::Instrument>& meter, const ResolvedDevice& resolved,
                                      const drivers::Identity& identity, std::vector<std::string> apertures) {
  auto id = db_.ensure_instrument(instrument_record(identity, device_));
  if (!id)
    spdlog::error("event=instrument_not_stored serial={} kind={} error=\"{}\"", identity.serial_number,
                  store::to_string(id.error().kind), id.error().message);
  std::lock_guard lock(mutex_);
  meter_ = meter;  // again: a detach reported while connecting is outdated by this contact
  identity_ = identity;
  apertures_ = std::move(apertures);
  if (!model_.forced) expected_model_ = identity.model;
  if (id) instrument_id_ = *id;
  adapter_ = resolved.adapter;
  ever_connected_ = true;
  failed_attempts_ = 0;
  next_attempt_.reset();
  next_check_ = SteadyClock::now() + link_.check_interval;
  next_hangup_look_ = SteadyClock::now() + kHangupLook;
  state_ = api::InstrumentState::connected;
  spdlog::info("event=instrument_connected device=\"{}\" port=\"{}\" model=\"{}\" serial={}", device_, port_,
               identity.reported_model, identity.serial_number);
  for (const auto& warning : identity.warnings)
    spdlog::warn("event=instrument_identity serial={} warning=\"{}\"", identity.serial_number, warning);
}

// ---- In the background ------------------------------------------------------------------

void ConnectionKeeper::start(Settings settings) {
  {
    std::lock_guard lock(mutex_);
    link_ = std::move(settings);
    next_attempt_ = SteadyClock::now();
  }
  if (link_.hotplug && follows_usb_adapters(device_)) {
    hotplug_ = drivers::HotplugMonitor::start([this](const drivers::UsbDeviceEvent& event) { on_usb_event(event); });
    if (hotplug_) spdlog::info("event=hotplug_monitor mode={}", hotplug_->polling() ? "polling" : "libusb");
  }
  connector_ = std::jthread([this] { keep_connected(); });
}

void ConnectionKeeper::keep_connected() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    const auto due = next_link_action();
    if (!due) {
      wake_.wait(lock);
    } else if (SteadyClock::now() < *due) {
      wake_.wait_until(lock, *due);
    } else {
      lock.unlock();
      connect_or_check();
      lock.lock();
    }
  }
}

// When the connector has something to do (mutex_ held); nullopt: nothing until woken.
std::optional<SteadyClock::time_point> ConnectionKeeper::next_link_action() const {
  if (jobs_waiting_()) return SteadyClock::now() + kBusyRecheck;
  if (meter_)
    return link_.check_interval > milliseconds::zero() ? std::min(next_check_, next_hangup_look_) : next_hangup_look_;
  return next_attempt_;
}

void ConnectionKeeper::connect_or_check() {
  const auto wire = wire_.hold();
  std::shared_ptr<drivers::Instrument> meter;
  {
    std::lock_guard lock(mutex_);
    // A job came meanwhile: its worker connects (at once, without waiting for the backoff).
    if (stopping_ || jobs_waiting_()) return;
    meter = meter_;
  }
  if (!meter) {
    (void)connect_holding_wire();
    return;
  }
  if (meter->link_closed()) {
    std::lock_guard lock(mutex_);
    if (meter_ == meter) lose_meter(fmt::format("lost: the link to {} was closed", meter_on_port()));
    return;
  }
  bool check_due = false;
  {
    std::lock_guard lock(mutex_);
    next_hangup_look_ = SteadyClock::now() + kHangupLook;
    check_due = link_.check_interval > milliseconds::zero() && SteadyClock::now() >= next_check_;
  }
  if (check_due) check_holding_wire(meter);
}

// An idle meter is asked for its serial number, a short exchange that changes none of its
// settings, to notice a meter that was switched off or a link that broke while nobody measured.
void ConnectionKeeper::check_holding_wire(const std::shared_ptr<drivers::Instrument>& meter) {
  auto answered = meter->check();
  {
    std::lock_guard lock(mutex_);
    next_check_ = SteadyClock::now() + link_.check_interval;
  }
  if (!answered && answered.error().kind != Kind::cancelled) note_instrument_error(answered.error());
}

void ConnectionKeeper::on_usb_event(const drivers::UsbDeviceEvent& event) {
  std::lock_guard lock(mutex_);
  if (event.kind == drivers::UsbDeviceEvent::Kind::attached) {
    // Perhaps the meter's adapter: try now rather than when the backoff says.
    if (!meter_) next_attempt_ = SteadyClock::now();
  } else if (meter_ && adapter_ && concerns(event, *adapter_)) {
    // The meter cannot be used any more; a running job fails on its own and says why.
    lose_meter(fmt::format("lost: the USB device {:04x}:{:04x} of {} was unplugged", event.vendor_id, event.product_id,
                           port_));
  }
  wake_.notify_all();
}

}  // namespace skinspec::daemon
