// The real PR-650 driver against the simulated meter over an in-process link, at time scale 0:
// a clean session, and every fault ending in the error or recovery the driver promises.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <thread>

#include "skinspec/drivers/pr650.hpp"
#include "skinspec/simulator/meter.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "support/simulator_rig.hpp"

namespace skinspec::simulator {
namespace {

using drivers::InstrumentError;
using drivers::MeasureOptions;
using testing::fast_driver;
using testing::fast_meter;
using ::testing::HasSubstr;
using testing::MeterRig;
using testing::observer;
using testing::skin_scene;
using testing::white_scene;
using Kind = InstrumentError::Kind;

// The printed values have 4 significant digits: within half a unit of the last one.
void expect_same_spectrum(const std::vector<double>& printed, const std::vector<double>& source) {
  ASSERT_EQ(printed.size(), source.size());
  for (std::size_t i = 0; i < source.size(); ++i)
    EXPECT_NEAR(printed[i], source[i], 5.01e-4 * source[i]) << "at " << native_grid()[i] << " nm";
}

MeterOptions with_faults(std::vector<std::string> specs, MeterOptions options = fast_meter()) {
  auto plan = FaultPlan::parse(specs);
  EXPECT_TRUE(plan.has_value()) << plan.error();
  options.faults = *plan;
  return options;
}

Synthesis synthesis(std::vector<Scene> scenes) { return Synthesis{observer(), std::move(scenes)}; }

struct Session {
  MeterRig rig;
  std::unique_ptr<drivers::Pr650> driver;
  Session(std::vector<Scene> scenes, MeterOptions options = fast_meter(), drivers::DriverOptions d = fast_driver())
      : rig(synthesis(std::move(scenes)), std::move(options)), driver(rig.driver(d)) {}
};

MeasureOptions fixed(int integration_ms, bool adjust) {
  MeasureOptions o;
  o.integration_ms = integration_ms;
  o.adjust_integration = adjust;
  return o;
}

// A fixed time that suits the white at 100 cd/m2. With it the driver waits for a silent or cut
// M0 reply about 2 x 400 ms, not the 2 x 6 s that adaptive integration may take.
MeasureOptions quick() { return fixed(400, false); }

// ---- A clean session ---------------------------------------------------------------------

TEST(SimulatorDriver, CleanSessionReadsTheSourceRadianceWithinPrintedPrecision) {
  const Scene white = white_scene();
  Session s({white});
  ASSERT_TRUE(s.driver->connect());
  auto identity = s.driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->serial_number, "60912345");
  EXPECT_EQ(identity->configuration.points, 101);
  EXPECT_EQ(identity->configuration.first_nm, 380);
  EXPECT_EQ(identity->configuration.last_nm, 780);
  EXPECT_EQ(identity->configuration.step_nm, 4);

  auto reading = s.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->quality_code, 0);
  EXPECT_EQ(reading->attempts, 1);
  expect_same_spectrum(reading->radiance, white.radiance);
  EXPECT_EQ(reading->wavelength_nm, native_grid());

  const Photometry p = photometry(white.radiance, observer());
  EXPECT_NEAR(reading->luminance, 100 * 0.99, 0.1);
  EXPECT_NEAR(reading->luminance, p.Y, 5e-4 * p.Y);
  EXPECT_NEAR(reading->x, p.x, 1e-4);
  EXPECT_NEAR(reading->y, p.y, 1e-4);
  EXPECT_NEAR(reading->xyz[0], p.X, 5e-4 * p.X);
  EXPECT_NEAR(reading->xyz[2], p.Z, 5e-4 * p.Z);
  double sum = 0;
  for (const double v : white.radiance) sum += v;
  EXPECT_NEAR(reading->integrated, 4 * sum, 5e-4 * 4 * sum);
  EXPECT_EQ(s.rig.meter().measurements(), 1u);
  EXPECT_TRUE(s.rig.meter().problems().empty());
}

TEST(SimulatorDriver, ScriptedSessionMeasuresOneSceneAfterAnotherAndRepeatsTheLast) {
  const Scene white = white_scene(), skin = skin_scene();
  Session s({white, skin});
  ASSERT_TRUE(s.driver->connect());
  for (const Scene* expected : {&white, &skin, &skin}) {
    auto reading = s.driver->measure({});
    ASSERT_TRUE(reading) << reading.error().message;
    expect_same_spectrum(reading->radiance, expected->radiance);
  }
}

TEST(SimulatorDriver, SeededNoiseIsRepeatableAndOfTheAskedSize) {
  MeterOptions options = fast_meter();
  options.noise = 0.01;
  options.seed = 42;
  const Scene white = white_scene();
  std::vector<std::vector<double>> runs;
  for (int run = 0; run < 2; ++run) {
    Session s({white}, options);
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure({});
    ASSERT_TRUE(reading) << reading.error().message;
    runs.push_back(reading->radiance);
  }
  EXPECT_EQ(runs[0], runs[1]);
  double squares = 0;
  for (std::size_t i = 0; i < white.radiance.size(); ++i) squares += std::pow(runs[0][i] / white.radiance[i] - 1, 2);
  const double rms = std::sqrt(squares / static_cast<double>(white.radiance.size()));
  EXPECT_GT(rms, 0.006);
  EXPECT_LT(rms, 0.014);
}

TEST(SimulatorDriver, SkinUnderTheSameLampReadsItsReflectanceRelativeToTheWhite) {
  Session s({white_scene(), skin_scene()});
  ASSERT_TRUE(s.driver->connect());
  auto white = s.driver->measure({});
  auto skin = s.driver->measure({});
  ASSERT_TRUE(white && skin);
  auto bytes = read_file(std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv");
  auto reflectance = (*parse_spectra_csv(*bytes, "forearm.csv"))[1].spectrum;
  for (const double nm : {452.0, 552.0, 652.0}) {
    const auto i = static_cast<std::size_t>((nm - 380) / 4);
    EXPECT_NEAR(skin->radiance[i] / white->radiance[i] * 0.99, reflectance.at(nm), 1e-3) << nm << " nm";
  }
}

// ---- Sync failures ------------------------------------------------------------------------

class SyncFailure : public ::testing::TestWithParam<int> {};

TEST_P(SyncFailure, FallsBackToAnUnsyncedMeasurement) {
  Session s({white_scene()}, with_faults({fmt::format("m0:quality={}@1", GetParam())}));
  ASSERT_TRUE(s.driver->connect());
  MeasureOptions options;
  options.sync = MeasureOptions::Sync::automatic;
  auto reading = s.driver->measure(options);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->attempts, 2);
  EXPECT_EQ(reading->sync, "off");
  expect_same_spectrum(reading->radiance, white_scene().radiance);
}

INSTANTIATE_TEST_SUITE_P(Codes, SyncFailure, ::testing::Values(7, 8));

TEST(SimulatorDriver, SteadyLightCannotBeSyncedToSoItIsMeasuredUnsynced) {
  Scene steady = white_scene();
  steady.flicker_hz = 0;
  Session s({steady});
  ASSERT_TRUE(s.driver->connect());
  MeasureOptions options;
  options.sync = MeasureOptions::Sync::automatic;
  auto reading = s.driver->measure(options);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->sync, "off");
  EXPECT_EQ(reading->attempts, 1);
}

TEST(SimulatorDriver, FlickeringLightIsMeasuredInSync) {
  Session s({white_scene()});
  ASSERT_TRUE(s.driver->connect());
  MeasureOptions options;
  options.sync = MeasureOptions::Sync::automatic;
  auto reading = s.driver->measure(options);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_THAT(reading->sync, HasSubstr("60.02"));
}

// ---- Low light, overload and the stale buffer ---------------------------------------------

TEST(SimulatorDriver, LowLightIsABadReadingAndTheStaleDataLinesAreNeverReturned) {
  const Scene white = white_scene(), dim = white_scene(0.5);
  Session s({white, dim});
  ASSERT_TRUE(s.driver->connect());
  auto first = s.driver->measure({});
  ASSERT_TRUE(first) << first.error().message;
  auto second = s.driver->measure({});
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().kind, Kind::bad_reading);
  EXPECT_EQ(second.error().quality_code, 18);
  // The meter kept the white's data lines: they are in the raw reply, never in a reading.
  auto stale = drivers::pr650::parse_spectral(second.error().raw_reply);
  ASSERT_TRUE(stale);
  EXPECT_EQ(stale->quality, 18);
  EXPECT_EQ(stale->values, first->radiance);
}

TEST(SimulatorDriver, VeryWeakLightGivesQualityTen) {
  Session s({white_scene(0.05)});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::bad_reading);
  EXPECT_EQ(reading.error().quality_code, 10);
}

// The detector level at a fixed integration time, as the meter's sensor model sees it.
double level(const Scene& scene, int integration_ms) {
  return std::ranges::max(scene.radiance) * integration_ms / SensorModel{}.full_scale;
}

TEST(SimulatorDriver, LowLightAtAFixedTimeWithoutAdjustingIsABadReading) {
  const Scene white = white_scene(200);
  ASSERT_LT(level(white, 20), SensorModel{}.low_light);
  Session s({white});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(fixed(20, false));
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().quality_code, 18);
}

TEST(SimulatorDriver, LowLightWithAdjustIntegrationDoublesTheTimeUntilTheReadingIsGood) {
  const Scene white = white_scene(200);
  ASSERT_LT(level(white, 20), SensorModel{}.low_light);
  ASSERT_GE(level(white, 160), SensorModel{}.low_light);
  Session s({white});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(fixed(20, true));
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_GT(reading->attempts, 1);
  EXPECT_GT(reading->integration_ms, 20);
  expect_same_spectrum(reading->radiance, white.radiance);
}

TEST(SimulatorDriver, OverloadWithoutAdjustingIsABadReading) {
  const Scene white = white_scene(200);
  ASSERT_GT(level(white, 3000), 1);
  Session s({white});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(fixed(3000, false));
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::bad_reading);
  EXPECT_EQ(reading.error().quality_code, 19);
}

TEST(SimulatorDriver, OverloadWithAdjustIntegrationHalvesTheTimeUntilTheReadingIsGood) {
  const Scene white = white_scene(200);
  Session s({white});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(fixed(3000, true));
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_GT(reading->attempts, 1);
  EXPECT_LT(reading->integration_ms, 3000);
  expect_same_spectrum(reading->radiance, white.radiance);
}

TEST(SimulatorDriver, LightTooBrightEvenForTheShortestTimeOverloads) {
  Session s({white_scene(20000)});
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().quality_code, 19);
}

class QualityFault : public ::testing::TestWithParam<int> {};

TEST_P(QualityFault, EndsInABadReadingWithThatCode) {
  Session s({white_scene()}, with_faults({fmt::format("m0:quality={}", GetParam())}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::bad_reading);
  EXPECT_EQ(reading.error().quality_code, GetParam());
}

INSTANTIATE_TEST_SUITE_P(Codes, QualityFault, ::testing::Values(7, 8, 10, 18, 19));

TEST(SimulatorDriver, StaleFaultAfterAGoodMeasurementIsNeverReturned) {
  const Scene white = white_scene(), skin = skin_scene();
  Session s({white, skin}, with_faults({"m0:stale@2"}));
  ASSERT_TRUE(s.driver->connect());
  ASSERT_TRUE(s.driver->measure({}));
  auto failed = s.driver->measure({});
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().quality_code, 18);
  auto retried = s.driver->measure({});
  ASSERT_TRUE(retried) << retried.error().message;
  expect_same_spectrum(retried->radiance, skin.radiance);
}

TEST(SimulatorDriver, MeterThatReportsQualityInTheM0StatusIsJudgedByItsReport) {
  MeterOptions options = fast_meter();
  options.m0_reports_quality = true;
  Session s({white_scene(0.5)}, options);
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::bad_reading);
  EXPECT_EQ(reading.error().quality_code, 18);
}

// ---- Damaged replies ------------------------------------------------------------------------

struct DamageCase {
  std::string fault;  // hits every time
  std::string once;   // hits the first time only
};

class DamagedReply : public ::testing::TestWithParam<DamageCase> {};

TEST_P(DamagedReply, EveryTimeEndsInAProtocolError) {
  Session s({white_scene()}, with_faults({GetParam().fault}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::protocol) << reading.error().message;
}

TEST_P(DamagedReply, OnceIsRecoveredFrom) {
  Session s({white_scene()}, with_faults({GetParam().once}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  expect_same_spectrum(reading->radiance, white_scene().radiance);
}

INSTANTIATE_TEST_SUITE_P(
    Faults, DamagedReply,
    ::testing::Values(DamageCase{"d5:truncate", "d5:truncate@1"}, DamageCase{"d5:truncate=1000", "d5:truncate=1000@1"},
                      DamageCase{"d5:garbage", "d5:garbage@1"}, DamageCase{"d5:garbage=1", "d5:garbage=1@1"},
                      DamageCase{"d5:drop-line", "d5:drop-line@1"}, DamageCase{"d5:drop-line=1", "d5:drop-line=1@1"},
                      DamageCase{"d5:line-count=100", "d5:line-count=100@1"},
                      DamageCase{"d5:line-count=102", "d5:line-count=102@1"}, DamageCase{"s:garbage", "s:garbage@1"},
                      DamageCase{"s:truncate=1", "s:truncate=1@1"}, DamageCase{"d1:garbage", "d1:garbage@1"},
                      DamageCase{"d2:truncate", "d2:truncate@1"}, DamageCase{"d2:garbage=3", "d2:garbage=3@1"}),
    [](const ::testing::TestParamInfo<DamageCase>& param_info) {
      std::string name = param_info.param.fault;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST(SimulatorDriver, ADamagedMeasurementStatusIsNotMeasuredAgain) {
  // The meter answered, so it measured: the report that follows carries the measurement.
  for (const std::string spec : {"m0:garbage", "m0:truncate=2", "m0:bitflip=3"}) {
    Session s({white_scene()}, with_faults({spec}));
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure(quick());
    ASSERT_TRUE(reading) << spec << ": " << reading.error().message;
    EXPECT_TRUE(reading->warnings.empty()) << spec;
    EXPECT_EQ(reading->attempts, 1) << spec;
    EXPECT_EQ(s.rig.meter().measurements(), 1u) << spec;
    expect_same_spectrum(reading->radiance, white_scene().radiance);
  }
  // Nothing at all came back (the only line dropped): measured again, and the reading says so.
  Session s({white_scene()}, with_faults({"m0:drop-line@1"}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(quick());
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(s.rig.meter().measurements(), 2u);
  EXPECT_EQ(reading->attempts, 2);
  EXPECT_EQ(reading->warnings.size(), 1u);
}

// A command the meter never heard: the reply is asked for again (setup, reports), or the meter
// measures once more and the reading says so (M0).
TEST(SimulatorDriver, OneLostReplyToAnyCommandIsRecovered) {
  for (const std::string command : {"s", "m0", "d5", "d1", "d2"}) {
    Session s({white_scene()}, with_faults({command + ":no-answer@1"}));
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure(quick());
    ASSERT_TRUE(reading) << command << ": " << reading.error().message;
    expect_same_spectrum(reading->radiance, white_scene().radiance);
    EXPECT_EQ(s.rig.meter().measurements(), 1u) << command;  // the lost M0 was never carried out
    if (command == "m0") {
      EXPECT_EQ(reading->attempts, 2);
      ASSERT_EQ(reading->warnings.size(), 1u);
      EXPECT_THAT(reading->warnings[0], ::testing::StartsWith("remeasured: the PR-650 did not answer 'm0'"));
    } else {
      EXPECT_TRUE(reading->warnings.empty()) << command;
    }
  }
  for (const std::string command : {"d110", "d120"}) {
    Session s({white_scene()}, with_faults({command + ":no-answer@1"}));
    ASSERT_TRUE(s.driver->connect());
    auto identity = s.driver->identify();
    ASSERT_TRUE(identity) << command << ": " << identity.error().message;
    EXPECT_EQ(identity->serial_number, "60912345");
  }
}

TEST(SimulatorDriver, BitFlipsNeverPassUnnoticedBeyondTheValuesTheyHit) {
  // A flipped bit may turn a digit into another digit, which no parser can notice; anything
  // else must be caught. So either an error, or a reading off in at most the flipped values.
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    MeterOptions options = with_faults({"d5:bitflip=2"});
    options.seed = seed;
    Session s({white_scene()}, options);
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure({});
    if (!reading) {
      EXPECT_THAT(reading.error().kind, ::testing::AnyOf(Kind::protocol, Kind::bad_reading)) << reading.error().message;
      continue;
    }
    int off = 0;
    for (std::size_t i = 0; i < reading->radiance.size(); ++i)
      off += std::abs(reading->radiance[i] / white_scene().radiance[i] - 1) > 5.01e-4;
    EXPECT_LE(off, 2) << "seed " << seed;
  }
}

TEST(SimulatorDriver, ExponentAndHeaderVariantsReadTheSame) {
  const Scene white = white_scene();
  for (const std::string spec : {"*:exponent=e", "d5:header=h2", "d5:header=h1"}) {
    Session s({white}, with_faults({spec}));
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure({});
    ASSERT_TRUE(reading) << spec << ": " << reading.error().message;
    expect_same_spectrum(reading->radiance, white.radiance);
  }
  MeterOptions options = fast_meter();
  options.style = {drivers::pr650::HeaderVariant::h2_two_lines, 'e'};
  Session s({white}, options);
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_THAT(reading->raw_reply, HasSubstr("\r\n0380.,"));
  EXPECT_THAT(reading->raw_reply, HasSubstr("e-0"));
}

// ---- A meter that goes away -----------------------------------------------------------------

TEST(SimulatorDriver, DisconnectInTheMiddleOfAReportIsALostInstrument) {
  Session s({white_scene()}, with_faults({"d5:disconnect=800"}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::lost) << reading.error().message;
  EXPECT_EQ(s.rig.wait_for_end(), SimulatedMeter::ServeEnd::disconnected);
}

TEST(SimulatorDriver, NoAnswerToTheFirstContactIsNoContact) {
  Session s({white_scene()}, with_faults({"b:no-answer"}));
  auto connected = s.driver->connect();
  ASSERT_FALSE(connected);
  EXPECT_EQ(connected.error().kind, Kind::no_contact);
}

TEST(SimulatorDriver, OneLostContactCommandIsRetried) {
  Session s({white_scene()}, with_faults({"b3:no-answer@1"}));
  EXPECT_TRUE(s.driver->connect());
}

TEST(SimulatorDriver, NoAnswerLaterIsALostInstrument) {
  for (const std::string spec : {"m0:no-answer", "d5:no-answer", "d110:no-answer", "s:no-answer"}) {
    Session s({white_scene()}, with_faults({spec}));
    ASSERT_TRUE(s.driver->connect());
    const bool identify = spec.starts_with("d110");
    const auto error = identify ? s.driver->identify().error() : s.driver->measure(quick()).error();
    EXPECT_EQ(error.kind, Kind::lost) << spec << ": " << error.message;
    EXPECT_THAT(error.message, HasSubstr(spec.starts_with("m0") ? "(measured twice)" : "(asked twice)")) << spec;
  }
}

// The driver waits 300 ms for a report's first byte, 600 ms when it asks again (fast_driver()).
TEST(SimulatorDriver, ALateReplyIsTakenWithinTheSecondRequestsWaitBeyondItTheMeterIsLost) {
  {
    Session s({white_scene()}, with_faults({"d1:late=50@1"}));
    ASSERT_TRUE(s.driver->connect());
    EXPECT_TRUE(s.driver->measure(quick()));
    EXPECT_EQ(s.rig.meter().commands(), 6u);  // b3 s m0 d5 d1 d2
  }
  {
    // Asked again at 300 ms; the first reply comes at 450 ms, the meter's answer to the second
    // request right after it, and the next command still gets its own reply.
    Session s({white_scene()}, with_faults({"d1:late=450@1"}));
    ASSERT_TRUE(s.driver->connect());
    auto reading = s.driver->measure(quick());
    ASSERT_TRUE(reading) << reading.error().message;
    EXPECT_EQ(s.rig.meter().commands(), 7u);  // b3 s m0 d5 d1 d1 d2
    EXPECT_DOUBLE_EQ(reading->xyz[1], reading->luminance);
    EXPECT_TRUE(s.driver->measure(quick()));
  }
  Session s({white_scene()}, with_faults({"d1:late=1500@1"}));
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure(quick());
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, Kind::lost);
}

TEST(SimulatorDriver, RebootLosesTheMeterUntilItIsPowerCycled) {
  Session s({white_scene()}, with_faults({"m0:reboot@2"}));
  ASSERT_TRUE(s.driver->connect());
  ASSERT_TRUE(s.driver->measure(quick()));
  auto lost = s.driver->measure(quick());
  ASSERT_FALSE(lost);
  EXPECT_EQ(lost.error().kind, Kind::lost);
  EXPECT_EQ(s.rig.meter().mode(), SimulatedMeter::Mode::local);
  auto again = s.driver->connect();
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().kind, Kind::no_contact);

  s.rig.meter().power_cycle();
  ASSERT_TRUE(s.driver->connect());
  auto reading = s.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  expect_same_spectrum(reading->radiance, white_scene().radiance);
}

// ---- Power-on window and echo ---------------------------------------------------------------

TEST(SimulatorDriver, MeterNotCommandedWithinItsWindowStaysSilentUntilPowerCycled) {
  MeterOptions options = fast_meter();
  options.boot_window_s = 0.05;
  Session s({white_scene()}, options);
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  EXPECT_EQ(s.rig.meter().mode(), SimulatedMeter::Mode::local);
  auto connected = s.driver->connect();
  ASSERT_FALSE(connected);
  EXPECT_EQ(connected.error().kind, Kind::no_contact);
  EXPECT_THAT(connected.error().message, HasSubstr("switch it off"));

  s.rig.meter().power_cycle();
  EXPECT_EQ(s.rig.meter().mode(), SimulatedMeter::Mode::boot);
  ASSERT_TRUE(s.driver->connect());
  EXPECT_EQ(s.rig.meter().mode(), SimulatedMeter::Mode::remote);
}

TEST(SimulatorDriver, MeterCommandedInTimeStaysRemoteAfterTheWindow) {
  MeterOptions options = fast_meter();
  options.boot_window_s = 0.5;
  Session s({white_scene()}, options);
  ASSERT_TRUE(s.driver->connect());
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  EXPECT_EQ(s.rig.meter().mode(), SimulatedMeter::Mode::remote);
  EXPECT_TRUE(s.driver->measure({}));
}

TEST(SimulatorDriver, DriverCopesWithAMeterInEchoMode) {
  MeterRig rig(synthesis({white_scene()}));
  EXPECT_EQ(testing::ask(*rig.host(), "e\n"), ">");
  auto driver = rig.driver();
  ASSERT_TRUE(driver->connect());
  ASSERT_TRUE(driver->identify());
  auto reading = driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  expect_same_spectrum(reading->radiance, white_scene().radiance);
}

}  // namespace
}  // namespace skinspec::simulator
