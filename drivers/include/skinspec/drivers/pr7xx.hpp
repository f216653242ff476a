#pragma once
// The PR-730/735/740/745/788: a measurement is triggered with T and polled with P until done;
// V gives its outcome and D5 its spectrum. cancel() aborts it on the meter with A. A meter
// busy with a measurement that was not aborted is waited for. A firmware that does not know T,
// P or A (the 2009 PR-730/735 manual lists none of them) is measured with M5 for the rest of the
// connection, as the PR-670 is, and the driver says so once (firmware_warnings()).

#include "skinspec/drivers/remote_meter.hpp"

namespace skinspec::drivers {

namespace remote {
struct Rule;
}

class Pr7xx final : public RemoteMeter {
 public:
  // `model` must be of family pr7xx (std::invalid_argument otherwise).
  Pr7xx(Model model, std::unique_ptr<Transport> transport, RemoteOptions options = {});

 private:
  std::expected<Spectrum, InstrumentError> take_spectrum(int exposure_ms, int cycles) override;
  std::expected<void, InstrumentError> wait_while_busy(std::string_view command) override;
  std::expected<int, InstrumentError> poll_until_done(std::chrono::milliseconds limit);
  // `limit`: how long the measurement may still run, should the meter not know A.
  std::expected<void, InstrumentError> abort_measurement(std::chrono::milliseconds limit);
  enum class Trigger { started, failed, unknown };  // unknown: T answered illegal command
  std::expected<Trigger, InstrumentError> trigger(const std::string& command, std::chrono::milliseconds limit);
  remote::Rule line_rule() const;
  int last_trigger_code_ = 0;  // what T answered when it did not start a measurement
};

}  // namespace skinspec::drivers
