// The supervisor's side facing the instrument: connecting, identifying, and what its state is.

#include <spdlog/spdlog.h>

#include "skinspec/drivers/transport.hpp"
#include "supervisor.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

json Supervisor::instrument_status() const {
  std::lock_guard lock(mutex_);
  return {{"device", device_},
          {"state", state_},
          {"last_error", last_error_.empty() ? json(nullptr) : json(last_error_)},
          {"serial_number", serial_number_.empty() ? json(nullptr) : json(serial_number_)},
          {"running_job", running_ ? json(*running_) : json(nullptr)},
          {"queued", queue_.size()}};
}

void Supervisor::set_state(std::string state) {
  std::lock_guard lock(mutex_);
  state_ = std::move(state);
}

void Supervisor::note_instrument_error(const drivers::InstrumentError& e) {
  using K = drivers::InstrumentError::Kind;
  std::lock_guard lock(mutex_);
  last_error_ = describe(e);
  if (e.kind == K::lost || e.kind == K::no_contact || e.kind == K::transport || e.kind == K::protocol) {
    // Start again from first contact on the next job.
    state_ = "lost";
    meter_.reset();
  } else {
    state_ = meter_ ? "connected" : "disconnected";
  }
}

std::optional<drivers::InstrumentError> Supervisor::ensure_connected() {
  using K = drivers::InstrumentError::Kind;
  {
    std::lock_guard lock(mutex_);
    if (meter_ && meter_->connected()) return std::nullopt;
  }
  auto uri = drivers::parse_connection_uri(device_);
  if (!uri) return drivers::InstrumentError{K::transport, "--device '" + device_ + "': " + uri.error(), -1, {}};
  auto transport = drivers::make_transport(*uri);
  if (!transport) return drivers::InstrumentError{K::transport, transport.error(), -1, {}};
  drivers::DriverOptions options;
  options.style.terminator = uri->terminator;
  auto meter = std::make_shared<drivers::Pr650>(std::move(*transport), options);
  {
    std::lock_guard lock(mutex_);
    meter_ = meter;  // visible to cancel() while connecting
  }
  if (auto ok = meter->connect(); !ok) return ok.error();
  auto identity = meter->identify();
  if (!identity) return identity.error();
  store::Instrument instrument;
  instrument.model = "PR-650";
  instrument.serial_number = identity->serial_number;
  instrument.spectral_configuration = json{{"grid_nm", "380-780/4"}}.dump();
  instrument.connection = device_;
  auto id = db_.ensure_instrument(instrument);
  std::lock_guard lock(mutex_);
  serial_number_ = identity->serial_number;
  if (id) instrument_id_ = *id;
  state_ = "connected";
  spdlog::info("event=instrument_connected device=\"{}\" serial={}", device_, serial_number_);
  return std::nullopt;
}

}  // namespace skinspec::daemon
