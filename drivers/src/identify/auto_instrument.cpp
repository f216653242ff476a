#include "identify/auto_instrument.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <mutex>

#include "identify/probe.hpp"

namespace skinspec::drivers::identify {

namespace {

InstrumentError not_connected() {
  return {InstrumentError::Kind::lost, "no meter is connected: connect() first", -1, {}};
}

class AutoInstrument final : public Instrument {
 public:
  AutoInstrument(std::unique_ptr<Transport> transport, InstrumentOptions options)
      : link_(std::move(transport)), options_(std::move(options)) {}
  ~AutoInstrument() override {
    disconnect();
    std::lock_guard lock(state_mutex_);
    driver_.reset();  // before the link it borrows
  }

  std::expected<void, InstrumentError> connect() override;
  void disconnect() override;
  bool connected() const override {
    auto driver = current();
    return driver && driver->connected();
  }
  bool link_closed() override {
    std::unique_lock lock(connect_mutex_, std::try_to_lock);
    if (!lock) return false;
    if (auto driver = current()) return driver->link_closed();
    return !link_->is_open();
  }
  std::uint64_t replies_received() const override {
    std::lock_guard lock(state_mutex_);
    return replies_before_ + (probe_ ? probe_->replies() : 0) + (driver_ ? driver_->replies_received() : 0);
  }
  std::expected<Identity, InstrumentError> identify() override;
  std::expected<void, InstrumentError> check() override {
    auto driver = current();
    if (!driver) return std::unexpected(not_connected());
    return driver->check();
  }
  std::expected<Reading, InstrumentError> measure(const MeasureOptions& options) override {
    auto driver = current();
    if (!driver) return std::unexpected(not_connected());
    return driver->measure(options);
  }
  void cancel() override {
    std::lock_guard lock(state_mutex_);
    if (probe_) probe_->cancel();
    if (driver_) driver_->cancel();
  }
  std::string describe() const override { return link_->describe(); }
  const std::string& serial_number() const override {
    static const std::string none;
    auto driver = current();
    return driver ? driver->serial_number() : none;
  }
  std::vector<std::string> firmware_warnings() const override {
    auto driver = current();
    return driver ? driver->firmware_warnings() : std::vector<std::string>{};
  }
  std::expected<std::vector<std::string>, InstrumentError> apertures() override {
    auto driver = current();
    if (!driver) return std::unexpected(not_connected());
    return driver->apertures();
  }
  // Before identification: as long as the slowest family's reading may take.
  std::chrono::milliseconds reading_time(const MeasureOptions& options) const override {
    if (auto driver = current()) return driver->reading_time(options);
    int longest = 0;
    for (const MeterProfile& row : all_profiles())
      longest = std::max({longest, row.exposure.max_ms, row.exposure.max_extended_ms});
    return std::chrono::milliseconds(2L * longest * std::max(options.averages, 1));
  }

 private:
  std::shared_ptr<Instrument> current() const {
    std::lock_guard lock(state_mutex_);
    return driver_;
  }
  // Lets the driver of an earlier connection go: it leaves remote mode; the link stays open, as
  // each driver's own connect() keeps it.
  void drop_driver();

  std::unique_ptr<Transport> link_;
  InstrumentOptions options_;
  std::mutex connect_mutex_;            // one connect() at a time
  mutable std::mutex state_mutex_;      // what follows, for calls from other threads
  std::shared_ptr<Instrument> driver_;  // the family found; borrows link_
  Probe* probe_ = nullptr;              // while connect() looks for the family
  std::atomic<bool> model_unresolved_{false};
  std::uint64_t replies_before_ = 0;  // of earlier drivers and probes
};

void AutoInstrument::drop_driver() {
  std::shared_ptr<Instrument> old;
  {
    std::lock_guard lock(state_mutex_);
    old = std::move(driver_);
    if (old) replies_before_ += old->replies_received();
  }
  if (old) old->disconnect();
}

void AutoInstrument::disconnect() {
  if (auto driver = current()) driver->disconnect();
  if (link_->is_open()) link_->close();
}

// Every connection finds the family again: the meter on the port may have been changed.
std::expected<void, InstrumentError> AutoInstrument::connect() {
  std::lock_guard connecting(connect_mutex_);
  drop_driver();
  Probe probe(*link_, options_);
  {
    std::lock_guard lock(state_mutex_);
    probe_ = &probe;
  }
  auto found = probe.run();
  std::lock_guard lock(state_mutex_);
  probe_ = nullptr;
  replies_before_ += probe.replies();
  if (!found) return std::unexpected(found.error());
  driver_ = std::move(found->driver);
  model_unresolved_ = found->model_unresolved;
  return {};
}

// A '/'-list of models whose grids D120 did not tell apart is reported as no model.
std::expected<Identity, InstrumentError> AutoInstrument::identify() {
  auto driver = current();
  if (!driver) return std::unexpected(not_connected());
  auto identity = driver->identify();
  if (identity && model_unresolved_) {
    identity->model.reset();
    identity->warnings.push_back(
        fmt::format("unresolved-model: '{}' names several models and the meter's grid ({}-{} nm by {} nm) is none "
                    "of theirs; measured as a {}",
                    identity->reported_model, identity->grid.first_nm, identity->grid.last_nm, identity->grid.step_nm,
                    to_string(identity->family)));
  }
  return identity;
}

}  // namespace

std::unique_ptr<Instrument> make_auto_instrument(std::unique_ptr<Transport> transport, InstrumentOptions options) {
  return std::make_unique<AutoInstrument>(std::move(transport), std::move(options));
}

}  // namespace skinspec::drivers::identify
