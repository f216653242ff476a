// The PR-650 driver against a scripted meter on an in-process link: every byte and delay is
// under the test's control.

#include "skinspec/drivers/pr650.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <expected>
#include <thread>

#include "skinspec/drivers/memory_transport.hpp"
#include "support/driver_options.hpp"
#include "support/scripted_meter.hpp"

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::MeterStep;
using testing::ScriptedMeter;

DriverOptions fast_options() { return testing::fast_driver(); }

// A smooth lamp spectrum with a given scale, as the meter would print it.
pr650::SpectralReport lamp(double scale, int quality = 0) {
  pr650::SpectralReport r;
  r.quality = quality;
  double sum = 0;
  for (int i = 0; i < pr650::kSpectralPoints; ++i) {
    const double nm = 380 + 4.0 * i;
    r.wavelength_nm.push_back(nm);
    const double v = scale * (1 + 0.5 * std::sin(nm / 40));
    r.values.push_back(std::stod(pr650::format_value(v)));
    sum += r.values.back();
  }
  r.integrated = sum * 4;
  return r;
}

std::string d5(double scale, int quality = 0) { return pr650::format_spectral_reply(lamp(scale, quality)); }
const std::string kOk = "000\r\n";
const std::string kSetupOk = "00\r\n";
const std::string kD1 = "00,0,1.000E+02,.3355,.3270\r\n";
const std::string kD2 = "00,0,1.026E+02,1.000E+02,1.032E+02\r\n";

std::vector<MeterStep> contact() { return {{"b3", kOk}}; }

std::vector<MeterStep> measurement(const std::string& setup, const std::string& spectral_reply) {
  return {{setup, kSetupOk}, {"m0", kOk, 20ms}, {"d5", spectral_reply}, {"d1", kD1}, {"d2", kD2}};
}

// A measurement whose quality code ends it after the spectral report: no D1/D2 follow.
std::vector<MeterStep> failed_measurement(const std::string& setup, const std::string& spectral_reply) {
  return {{setup, kSetupOk}, {"m0", kOk, 20ms}, {"d5", spectral_reply}};
}

std::vector<MeterStep> operator+(std::vector<MeterStep> a, const std::vector<MeterStep>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

struct Rig {
  std::unique_ptr<ScriptedMeter> meter;
  std::unique_ptr<Pr650> driver;
  MemoryTransport* host = nullptr;
};

Rig rig(std::vector<MeterStep> script, DriverOptions options = fast_options()) {
  auto [host, device] = make_memory_pair("memory:test");
  Rig r;
  r.host = dynamic_cast<MemoryTransport*>(host.get());
  r.meter = std::make_unique<ScriptedMeter>(std::move(device), std::move(script));
  r.driver = std::make_unique<Pr650>(std::move(host), options);
  return r;
}

TEST(Pr650Driver, ConnectsMeasuresAndReportsEverything) {
  auto r =
      rig(contact() + std::vector<MeterStep>{{"d110", "60912345\r\n"}, {"d120", "0101,008.0,0380.,0780.,004.\r\n"}} +
          measurement("s01,,,,,0,01,1", d5(1e-4)));
  ASSERT_TRUE(r.driver->connect());
  const auto identity = r.driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->serial_number, "60912345");
  EXPECT_EQ(identity->configuration.points, 101);

  const auto reading = r.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
  EXPECT_EQ(reading->quality_code, 0);
  EXPECT_EQ(reading->quality, "Measurement OK");
  ASSERT_EQ(reading->radiance.size(), 101u);
  EXPECT_DOUBLE_EQ(reading->wavelength_nm.front(), 380);
  EXPECT_DOUBLE_EQ(reading->wavelength_nm.back(), 780);
  EXPECT_EQ(reading->radiance, lamp(1e-4).values);
  EXPECT_EQ(reading->units, "W/(sr m2 nm)");
  EXPECT_EQ(reading->luminance_units, "cd/m2");
  EXPECT_DOUBLE_EQ(reading->luminance, 100);
  EXPECT_DOUBLE_EQ(reading->x, 0.3355);
  EXPECT_DOUBLE_EQ(reading->xyz[2], 103.2);
  EXPECT_EQ(reading->serial_number, "60912345");
  EXPECT_THAT(reading->raw_reply, HasSubstr("0380.,"));
  EXPECT_LE(reading->started, reading->finished);
}

TEST(Pr650Driver, TogglesModemLinesBeforeFirstContact) {
  auto r = rig(contact());
  ASSERT_TRUE(r.driver->connect());
  const auto changes = r.host->modem_line_changes();
  ASSERT_GE(changes.size(), 2u);
  EXPECT_EQ(changes.front(), (std::pair{false, false}));
  EXPECT_EQ(changes.back(), (std::pair{true, true}));
}

TEST(Pr650Driver, RetriesFirstContactAndGivesUpWithPowerCycleAdvice) {
  auto late = rig({{"b3", ""}, {"b3", ""}, {"b3", kOk}});
  EXPECT_TRUE(late.driver->connect());
  EXPECT_EQ(late.meter->commands().size(), 3u);

  auto silent = rig({{"b3", ""}, {"b3", ""}, {"b3", ""}});
  const auto result = silent.driver->connect();
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, InstrumentError::Kind::no_contact);
  EXPECT_THAT(result.error().message, HasSubstr("switch it off, switch it on"));
  EXPECT_EQ(silent.meter->commands().size(), 3u);
}

TEST(Pr650Driver, FallsBackToNoSyncWhenTheLightCannotBeLockedTo) {
  auto r = rig(contact() + std::vector<MeterStep>{{"f", "00,60.02\r\n"}} +
               failed_measurement("s01,,,,1,0,01,1", d5(1e-4, 8)) + measurement("s01,,,,,0,01,1", d5(2e-4)));
  ASSERT_TRUE(r.driver->connect());
  MeasureOptions options;
  options.sync = MeasureOptions::Sync::automatic;
  const auto reading = r.driver->measure(options);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
  EXPECT_EQ(reading->attempts, 2);
  EXPECT_EQ(reading->sync, "off");
  EXPECT_EQ(reading->radiance, lamp(2e-4).values);
}

TEST(Pr650Driver, UsesTheMeasuredFlickerFrequency) {
  auto r = rig(contact() + std::vector<MeterStep>{{"f", "00,60.02\r\n"}} + measurement("s01,,,,1,0,01,1", d5(1e-4)));
  ASSERT_TRUE(r.driver->connect());
  MeasureOptions options;
  options.sync = MeasureOptions::Sync::automatic;
  const auto reading = r.driver->measure(options);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_THAT(reading->sync, HasSubstr("60.02 Hz"));
}

TEST(Pr650Driver, LowLightIsABadReadingAndNeverAStaleSpectrum) {
  // The meter answers 18 with the data lines of the previous measurement: they must not come out.
  auto r =
      rig(contact() + measurement("s01,,,,,0,01,1", d5(1e-4)) + failed_measurement("s01,,,,,0,01,1", d5(1e-4, 18)));
  ASSERT_TRUE(r.driver->connect());
  ASSERT_TRUE(r.driver->measure({}));
  const auto dim = r.driver->measure({});
  ASSERT_FALSE(dim);
  EXPECT_EQ(dim.error().kind, InstrumentError::Kind::bad_reading);
  EXPECT_EQ(dim.error().quality_code, 18);
  EXPECT_THAT(dim.error().message, HasSubstr("Low light level"));
  EXPECT_THAT(dim.error().raw_reply, HasSubstr("18,0"));
}

TEST(Pr650Driver, DoublesIntegrationOnLowLightAndHalvesOnOverload) {
  auto r =
      rig(contact() + failed_measurement("s01,,,,,100,01,1", d5(1e-6, 18)) + measurement("s01,,,,,200,01,1", d5(1e-6)) +
          failed_measurement("s01,,,,,400,01,1", d5(1e-2, 19)) + measurement("s01,,,,,200,01,1", d5(1e-2)));
  ASSERT_TRUE(r.driver->connect());
  MeasureOptions options;
  options.integration_ms = 100;
  options.adjust_integration = true;
  const auto dim = r.driver->measure(options);
  ASSERT_TRUE(dim) << dim.error().message;
  EXPECT_EQ(dim->integration_ms, 200);
  options.integration_ms = 400;
  const auto bright = r.driver->measure(options);
  ASSERT_TRUE(bright) << bright.error().message;
  EXPECT_EQ(bright->integration_ms, 200);
  EXPECT_EQ(r.meter->mismatch(), "");
}

TEST(Pr650Driver, ReportsOverloadWithoutAdjustment) {
  auto r = rig(contact() + failed_measurement("s01,,,,,0,01,1", d5(1e-2, 19)));
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().quality_code, 19);
}

TEST(Pr650Driver, AsksAgainForAGarbledReportAndGivesUpOnASecond) {
  std::string garbled = d5(1e-4);
  garbled[garbled.find("0384.")] = '9';
  auto once =
      rig(contact() +
          std::vector<MeterStep>{
              {"s01,,,,,0,01,1", kSetupOk}, {"m0", kOk}, {"d5", garbled}, {"d5", d5(1e-4)}, {"d1", kD1}, {"d2", kD2}});
  ASSERT_TRUE(once.driver->connect());
  EXPECT_TRUE(once.driver->measure({}));

  auto twice = rig(contact() +
                   std::vector<MeterStep>{{"s01,,,,,0,01,1", kSetupOk}, {"m0", kOk}, {"d5", garbled}, {"d5", garbled}});
  ASSERT_TRUE(twice.driver->connect());
  const auto reading = twice.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, InstrumentError::Kind::protocol);
}

TEST(Pr650Driver, ASilentMeterAfterContactIsLost) {
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,10,01,1", kSetupOk}, {"m0", ""}});
  ASSERT_TRUE(r.driver->connect());
  MeasureOptions options;
  options.integration_ms = 10;
  const auto reading = r.driver->measure(options);
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, InstrumentError::Kind::lost);
  EXPECT_THAT(reading.error().message, HasSubstr("did not answer 'm0'"));
}

TEST(Pr650Driver, AnUnpluggedCableInTheMiddleOfAReportIsLost) {
  const std::string half = d5(1e-4).substr(0, 700);
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", kSetupOk}, {"m0", kOk}, {"d5", half, 0ms, true}});
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, InstrumentError::Kind::lost);
}

// A measurement cancelled from another thread once the meter has received `commands` commands
// and `after` more has passed, then the next measurement, which must read only its own replies.
std::expected<Reading, InstrumentError> cancel_then_measure(Rig& r, std::size_t commands,
                                                            std::chrono::milliseconds after) {
  std::jthread canceller([&] {
    while (r.meter->commands().size() < commands) std::this_thread::sleep_for(1ms);
    std::this_thread::sleep_for(after);
    r.driver->cancel();
  });
  const auto cancelled = r.driver->measure({});
  EXPECT_FALSE(cancelled);
  if (!cancelled) {
    EXPECT_EQ(cancelled.error().kind, InstrumentError::Kind::cancelled);
  }
  canceller.join();
  return r.driver->measure({});
}

TEST(Pr650Driver, CancelEndsAMeasurementAndTheNextOneStillWorks) {
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", kSetupOk}, {"m0", kOk, 400ms}} +
               measurement("s01,,,,,0,01,1", d5(1e-4)));
  ASSERT_TRUE(r.driver->connect());
  // Once the meter has the M0 and is measuring (400 ms). Its late "000" must not be taken for
  // the next command's reply.
  const auto reading = cancel_then_measure(r, 3, 0ms);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
}

// A cancel that lands while the spectral report streams in: the meter sends the rest of it all
// the same, and the next measurement's commands must not read it as their replies.
TEST(Pr650Driver, TheRestOfAReportACancelCutShortIsNotTakenForTheNextReply) {
  DriverOptions options = fast_options();
  options.timing.line_bytes_per_second = 4800;                                       // a whole report may take 0.8 s
  std::vector<MeterStep> streamed = failed_measurement("s01,,,,,0,01,1", d5(1e-4));  // up to D5
  streamed[2].line_interval = 5ms;                                                   // 101 data lines: about 0.5 s
  auto r = rig(contact() + streamed + measurement("s01,,,,,0,01,1", d5(2e-4)), options);
  ASSERT_TRUE(r.driver->connect());
  const auto reading = cancel_then_measure(r, 4, 60ms);  // the D5's first lines are out
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance, lamp(2e-4).values);
  EXPECT_EQ(r.meter->mismatch(), "");
}

TEST(Pr650Driver, AcceptsAnEchoingMeterWithPrompts) {
  // After someone sent E, the meter echoes each command and prompts with '>'.
  auto r = rig({{"b3", "b3\r\n000\r\n>"}});
  EXPECT_TRUE(r.driver->connect());
}

TEST(Pr650Driver, RefusesImpossibleSettingsWithoutTouchingTheMeter) {
  auto r = rig(contact());
  ASSERT_TRUE(r.driver->connect());
  MeasureOptions options;
  options.integration_ms = 7000;
  EXPECT_EQ(r.driver->measure(options).error().kind, InstrumentError::Kind::rejected);
  options.integration_ms = 0;
  options.averages = 0;
  EXPECT_EQ(r.driver->measure(options).error().kind, InstrumentError::Kind::rejected);
  EXPECT_EQ(r.meter->commands().size(), 1u);
}

TEST(Pr650Driver, ASetupTheMeterRefusesTwiceIsReported) {
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", "06\r\n"}, {"s01,,,,,0,01,1", "06\r\n"}});
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, InstrumentError::Kind::rejected);
  EXPECT_THAT(reading.error().message, HasSubstr("(asked twice)"));
}

TEST(Pr650Driver, ARefusalGivenOnceIsTakenForADamagedReply) {
  // "00" with one bit flipped reads as a refusal of field 1, 2, 4 or 8.
  auto r =
      rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", "04\r\n"}} + measurement("s01,,,,,0,01,1", d5(1e-4)));
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
}

TEST(Pr650Driver, AMeasurementThatNeverAnswersIsMadeOnceMoreAndTheReadingSaysSo) {
  auto r = rig(contact() +
               std::vector<MeterStep>{
                   {"s01,,,,,0,01,1", kSetupOk}, {"m0", ""}, {"m0", kOk}, {"d5", d5(1e-4)}, {"d1", kD1}, {"d2", kD2}});
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
  EXPECT_EQ(reading->attempts, 2);
  ASSERT_EQ(reading->warnings.size(), 1u);
  EXPECT_THAT(reading->warnings[0], HasSubstr("remeasured: the PR-650 did not answer 'm0' within 0.6 s"));
}

TEST(Pr650Driver, AGarbledMeasurementStatusGoesOnToTheReportWithoutMeasuringAgain) {
  for (const std::string status : {"0#0\r\n", "00", "018\r\n"}) {
    auto r =
        rig(contact() + std::vector<MeterStep>{
                            {"s01,,,,,0,01,1", kSetupOk}, {"m0", status}, {"d5", d5(1e-4)}, {"d1", kD1}, {"d2", kD2}});
    ASSERT_TRUE(r.driver->connect());
    const auto reading = r.driver->measure({});
    ASSERT_TRUE(reading) << reading.error().message;
    EXPECT_EQ(r.meter->mismatch(), "") << status;
    EXPECT_EQ(reading->attempts, 1);
    EXPECT_TRUE(reading->warnings.empty());
  }
}

TEST(Pr650Driver, AReportCutShortIsAskedForAgain) {
  const std::string half = d5(1e-4).substr(0, 700);
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", kSetupOk},
                                                  {"m0", kOk},
                                                  {"d5", half},
                                                  {"d5", d5(1e-4)},
                                                  {"d1", kD1.substr(0, 10)},
                                                  {"d1", kD1},
                                                  {"d2", kD2}});
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
  EXPECT_EQ(reading->radiance, lamp(1e-4).values);
  EXPECT_DOUBLE_EQ(reading->luminance, 100);
}

TEST(Pr650Driver, ALateReplyAndTheAnswerToTheSecondRequestAreNotTakenForTheNextReply) {
  // The first D1 is answered after 450 ms, past the 300 ms wait: the driver asks again, takes
  // the late reply, and lets the answer to its second request pass before D2.
  const std::string other_d1 = "00,0,9.999E+01,.3355,.3270\r\n";
  auto r = rig(contact() + std::vector<MeterStep>{{"s01,,,,,0,01,1", kSetupOk},
                                                  {"m0", kOk},
                                                  {"d5", d5(1e-4)},
                                                  {"d1", kD1, 450ms},
                                                  {"d1", other_d1},
                                                  {"d2", kD2}});
  ASSERT_TRUE(r.driver->connect());
  const auto reading = r.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(r.meter->mismatch(), "");
  EXPECT_DOUBLE_EQ(reading->luminance, 100);
  EXPECT_DOUBLE_EQ(reading->xyz[0], 102.6);
}

TEST(Pr650Driver, IdentificationAsksAgainForALostReply) {
  auto r = rig(contact() + std::vector<MeterStep>{
                               {"d110", ""}, {"d110", "60912345\r\n"}, {"d120", "0101,008.0,0380.,0780.,004.\r\n"}});
  ASSERT_TRUE(r.driver->connect());
  const auto identity = r.driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->serial_number, "60912345");
  EXPECT_EQ(r.meter->mismatch(), "");
}

TEST(Pr650Driver, AClosedLinkIsSeenWithoutAWordOnIt) {
  auto [host, device] = make_memory_pair("memory:test");
  Pr650 driver(std::move(host), fast_options());
  EXPECT_FALSE(driver.link_closed());
  device->close();
  EXPECT_TRUE(driver.link_closed());
}

// ---- The exchange rules: how long each reply may take, and what a lost one leads to --------

using pr650::CommandKind;
using pr650::LostReply;

TEST(ExchangeRules, AMeasurementMayTakeItsIntegrationsPlusTheOverheadOtherRepliesArriveQuickly) {
  const pr650::ReplyTiming timing;  // the defaults, for a real meter
  const auto m0 = pr650::exchange_rule({CommandKind::measure, 0, 1000, 3}, timing);
  EXPECT_EQ(m0.first_byte, 3 * 2 * 1000ms + timing.measurement_overhead);
  EXPECT_EQ(m0.on_lost, LostReply::measure_again);
  const auto adaptive = pr650::exchange_rule({CommandKind::measure, 0, 0, 2}, timing);
  EXPECT_EQ(adaptive.first_byte, 2 * timing.adaptive_allowance + timing.measurement_overhead);

  // A setup's reply within 0.5 s; a report's within 0.5 s plus its length at 9600 baud.
  for (const auto& [command, first_byte] :
       std::vector<std::pair<pr650::Command, std::chrono::milliseconds>>{{{CommandKind::setup}, 500ms},
                                                                         {{CommandKind::report, 1}, 566ms},
                                                                         {{CommandKind::report, 110}, 566ms},
                                                                         {{CommandKind::report, 5}, 2306ms}}) {
    const auto rule = pr650::exchange_rule(command, timing);
    EXPECT_EQ(rule.first_byte, first_byte);
    EXPECT_EQ(rule.on_lost, LostReply::ask_again);
    EXPECT_EQ(pr650::second_try(rule).first_byte, 2 * first_byte);
  }
  EXPECT_EQ(pr650::exchange_rule({CommandKind::contact}, timing).on_lost, LostReply::give_up);
  EXPECT_EQ(pr650::exchange_rule({CommandKind::report, 5}, timing).shape, pr650::ReplyShape::spectral);
  EXPECT_EQ(pr650::exchange_rule({CommandKind::report, 1}, timing).shape, pr650::ReplyShape::line);
}

TEST(ExchangeRules, PausesAndWholeRepliesFollowTheLineRate) {
  pr650::ReplyTiming timing;
  const auto d5 = pr650::exchange_rule({CommandKind::report, 5}, timing);
  EXPECT_EQ(d5.idle, timing.idle);  // at 9600 baud two data lines take 35 ms: the floor holds
  // A spectral report takes 1.8 s at 9600 baud: twice that, plus a pause, is allowed.
  EXPECT_GE(d5.whole, 3600ms);
  EXPECT_LT(d5.whole, 4000ms);
  timing.line_bytes_per_second = 30;  // 300 baud
  const auto slow = pr650::exchange_rule({CommandKind::report, 5}, timing);
  EXPECT_EQ(slow.idle, 1133ms);
  EXPECT_GT(slow.whole, 115s);

  EXPECT_EQ(driver_options_for(*parse_connection_uri("serial:/dev/ttyUSB0?baud=1200")).timing.line_bytes_per_second,
            120);
  EXPECT_EQ(driver_options_for(*parse_connection_uri("tcp:127.0.0.1:4001")).timing.line_bytes_per_second, 960);
  EXPECT_EQ(driver_options_for(*parse_connection_uri("tcp:127.0.0.1:4001?terminator=cr")).style.terminator, '\r');
}

}  // namespace
}  // namespace skinspec::drivers
