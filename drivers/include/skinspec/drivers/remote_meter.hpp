#pragma once
// What the drivers of the newer meters (PR-655/670/680: pr6xx.hpp; PR-7xx: pr7xx.hpp) share:
// remote mode entered with PHOTO and always left with Q, identification by D111/D110/D114/D120,
// setups sent only when they change, and the error policy for a failed measurement. How a
// measurement is taken differs by family; everything that differs by model is MeterProfile data.

#include <atomic>
#include <chrono>
#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "skinspec/drivers/remote_options.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

namespace remote {
class Session;
}

class RemoteMeter : public Instrument {
 public:
  ~RemoteMeter() override;
  RemoteMeter(const RemoteMeter&) = delete;
  RemoteMeter& operator=(const RemoteMeter&) = delete;

  std::expected<void, InstrumentError> connect() override;
  void disconnect() override;
  bool connected() const override { return connected_; }
  bool link_closed() override;
  std::uint64_t replies_received() const override;
  std::expected<Identity, InstrumentError> identify() override;
  // D110 alone: the four identification reports take about a second of paced bytes.
  std::expected<void, InstrumentError> check() override;
  std::expected<Reading, InstrumentError> measure(const MeasureOptions& options) override;
  void cancel() override;
  std::string describe() const override { return transport_->describe(); }
  const std::string& serial_number() const override { return identity_.serial_number; }
  std::vector<std::string> firmware_warnings() const override;
  std::expected<std::vector<std::string>, InstrumentError> apertures() override;
  std::chrono::milliseconds reading_time(const MeasureOptions& options) const override;

  const MeterProfile& profile() const { return profile_; }

  // Takes the meter as connected, on a port where identification (open_instrument.hpp) has
  // just entered remote mode: no second Q and PHOTO. `banner_glued` as identification found it.
  void adopt_remote_mode(bool banner_glued);

 protected:
  RemoteMeter(Family family, Model model, std::unique_ptr<Transport> transport, RemoteOptions options);

  // One measurement's spectral report, whose status may be one of the meter's error codes;
  // `remeasured` when it never answered and was taken again.
  struct Spectrum {
    pr6xx::SpectralReport report;
    std::string raw;
    bool remeasured = false;
  };
  // A measurement that ended with the meter's error `code`, without data.
  static Spectrum failed_with(int code) {
    Spectrum spectrum;
    spectrum.report.status = {code, 0};
    return spectrum;
  }
  virtual std::expected<Spectrum, InstrumentError> take_spectrum(int exposure_ms, int cycles) = 0;
  // M5, whose reply is the spectrum: the PR-655/670/680's measurement, and the PR-7xx's on a
  // firmware without T. A measurement that never answered is made once more; one whose reply
  // came damaged did measure, so D5 reads it again. There is no abort: a cancelled M5's reply is
  // dropped before the next command.
  std::expected<Spectrum, InstrumentError> measure_with_m5(int exposure_ms, int cycles);

  // What the meter on this connection turned out not to know, found from its refusals (an
  // older firmware: docs/pr6xx-protocol.md, "Firmware generations"), and what the driver does
  // instead. Forgotten on connect.
  struct Dialect {
    bool trigger = true;     // T, P, A and V; false: M5
    bool last_error = true;  // V
    SyncCommand sync = SyncCommand::ss;
    bool units = true;            // SU
    bool sensitivity = true;      // SH0 (standard sensitivity, as the meter starts)
    bool averages = true;         // SN01 (no averaging, as the meter starts)
    bool exposure_report = true;  // D13
  };
  const Dialect& dialect() const { return dialect_; }
  // The PR-7xx's trigger refused (`command` answered illegal command): M5 from now on, said once.
  void stop_triggering(std::string_view command);
  void without_last_error();

  remote::Session& session() { return *session_; }
  const RemoteOptions& options() const { return options_; }
  const Grid& grid() const { return identity_.grid; }
  // How long a measurement may take: a dark and a light exposure per cycle, plus overhead;
  // adaptive exposure may use the longest the model allows.
  std::chrono::milliseconds measurement_time(int exposure_ms, int cycles) const;
  // The cap on a whole reply of `points` data lines (0: one line), from the line rate.
  std::chrono::milliseconds whole_reply(int points) const;
  // A measurement a cancel could not stop, whose spectrum may still come within `limit`: dropped
  // before the next command.
  void measurement_pending(std::chrono::milliseconds limit);
  // Waits while the meter finishes a measurement, after it answered `command` with busy (1):
  // only meters that measure in the background say so. Others: a protocol error.
  virtual std::expected<void, InstrumentError> wait_while_busy(std::string_view command);
  // A spectral report (M5/D5) asked again once where `ask_again`, parsed against D120's grid.
  std::expected<Spectrum, InstrumentError> read_spectrum(std::string_view command, std::chrono::milliseconds first_byte,
                                                         bool ask_again);

 private:
  // What D111 says, against the profile this driver measures with.
  struct ReportedModel {
    std::string text;            // empty when the meter did not say
    std::optional<Model> model;  // the profile's; none for a model skinspec does not know
    std::optional<std::string> warning;
  };
  std::expected<ReportedModel, InstrumentError> ask_model();
  void forget_connection();
  void note_entry(bool banner_glued);
  std::expected<Identity, InstrumentError> query_identity();
  std::expected<void, InstrumentError> check(const MeasureOptions& options) const;
  int longest_exposure_ms(const MeasureOptions& options) const;
  std::expected<std::string, InstrumentError> configure(const MeasureOptions& options, int exposure_ms, bool sync_on);
  std::expected<std::string, InstrumentError> configure_sync(const MeasureOptions& options, bool sync_on);
  std::expected<void, InstrumentError> list_apertures();
  std::expected<int, InstrumentError> aperture_code(const std::string& name);
  // D13 after an adaptive measurement: the exposure the meter chose, or nullopt when it does
  // not say (a refusal is not the reading's failure).
  std::expected<std::optional<int>, InstrumentError> exposure_used();
  std::expected<void, InstrumentError> setup(std::optional<std::string>& last, const std::string& command,
                                             std::string_view range = {});
  std::expected<void, InstrumentError> read_colorimetry(Reading& reading, bool si_units);
  // A setup the meter answered illegal command: whether the driver may do without it (then it
  // says so once and sends it no more on this connection).
  struct Instead {
    std::string_view code;  // the warning's code: "no-units"
    std::string_view what;  // what the meter does then
  };
  bool do_without(const InstrumentError& error, bool& known, bool harmless, std::string_view command,
                  const Instead& instead);
  std::expected<void, InstrumentError> setup_sync_mode(pr6xx::SyncMode mode);
  void note_firmware(std::string warning);

  std::unique_ptr<Transport> transport_;
  const MeterProfile& profile_;
  RemoteOptions options_;
  std::unique_ptr<remote::Session> session_;
  Identity identity_;
  std::vector<std::string> connect_warnings_;  // how remote mode was entered, for every identity
  bool identified_ = false;
  std::atomic<bool> connected_{false};
  // The setups the meter holds on this connection: each is sent only when it changes.
  std::optional<std::string> units_, exposure_, averages_, sync_mode_, sync_frequency_, sensitivity_, aperture_;
  std::optional<std::vector<pr6xx::Aperture>> apertures_;  // D117, read once per connection when needed
  std::string unlisted_;                                   // why D117 listed none, for messages
  Dialect dialect_;
  mutable std::mutex warnings_mutex_;           // firmware_warnings_, read from any thread
  std::vector<std::string> firmware_warnings_;  // each fallback, said once per connection
  std::mutex call_mutex_;                       // one call on the wire at a time
};

}  // namespace skinspec::drivers
