// The drivers of the PR-655/670/680 (Pr6xx) and the PR-7xx (Pr7xx) against the simulated
// meters in process: remote mode in and out, identification, measurement on the meter's own
// grid, the error policy for every error code the simulator can produce, and the faults of the
// newer meters (a lost PHOTO, a glued banner, a truncated spectrum, a cancelled measurement).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "skinspec/drivers/pr6xx.hpp"
#include "skinspec/drivers/pr7xx.hpp"
#include "support/meter_bench.hpp"

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;
using simulator::MeterOptions;
using testing::fast_remote;
using ::testing::HasSubstr;
using testing::meter_options;
using testing::MeterRig;
using testing::synthesis_of;
using testing::white_on;
using Tap = testing::WireTap;
using K = InstrumentError::Kind;

// A simulated meter of `model` and a driver of its family on the other end of the link.
struct Bench {
  Bench(Model model, std::vector<std::string> faults = {}, RemoteOptions options = fast_remote(),
        MeterOptions meter = {}, double flicker_hz = 60)
      : scene(white_on(model, flicker_hz)),
        rig(synthesis_of(model, scene), meter.model == model ? std::move(meter) : meter_options(model, faults)) {
    auto tap = std::make_unique<Tap>(rig.take_host());
    written = tap->written();
    if (profile(model).family == Family::pr6xx) driver = std::make_unique<Pr6xx>(model, std::move(tap), options);
    else driver = std::make_unique<Pr7xx>(model, std::move(tap), options);
  }
  bool logged(std::string_view line) const {
    const auto log = rig.log();
    return std::ranges::any_of(log, [&](const std::string& l) { return l == line; });
  }
  simulator::Scene scene;
  MeterRig rig;
  std::function<std::string()> written;
  std::unique_ptr<RemoteMeter> driver;
};

// ---- Connect and identify ------------------------------------------------------------------

TEST(Pr6xxDriver, ConnectsAndIdentifiesEachFamilyOnItsGrid) {
  struct Case {
    Model model;
    int points, step_nm;
    std::optional<std::chrono::milliseconds> pacing;
  };
  // The PR-655 with the profile's own 50 ms pacing between bytes, the others unpaced.
  for (const Case c :
       {Case{Model::pr655, 101, 4, std::nullopt}, Case{Model::pr670, 201, 2, 0ms}, Case{Model::pr730, 401, 1, 0ms}}) {
    RemoteOptions options = fast_remote();
    options.pacing = c.pacing;
    Bench bench(c.model, {}, options);
    const auto& row = profile(c.model);
    ASSERT_TRUE(bench.driver->connect()) << row.id;
    EXPECT_TRUE(bench.logged("command PHOTO: remote mode")) << row.id;
    auto identity = bench.driver->identify();
    ASSERT_TRUE(identity) << row.id << ": " << identity.error().message;
    EXPECT_EQ(identity->model, c.model);
    EXPECT_EQ(identity->family, row.family);
    EXPECT_EQ(identity->reported_model, row.d111);
    EXPECT_EQ(identity->serial_number, row.serial);
    EXPECT_EQ(identity->firmware, "2.22D");
    EXPECT_EQ(identity->grid, (Grid{380, 780, c.step_nm, c.points})) << row.id;
    EXPECT_EQ(identity->configuration.points, c.points);
    EXPECT_TRUE(identity->warnings.empty());
    EXPECT_TRUE(bench.written().starts_with("QPHOTOD111\r")) << row.id << ": Q first, then PHOTO";
  }
}

// The idle check asks for the serial number alone: the four identification reports would keep
// a paced meter's line busy for about a second every few seconds.
TEST(Pr6xxDriver, TheIdleCheckIsOneSerialNumberReport) {
  Bench bench(Model::pr670);
  ASSERT_TRUE(bench.driver->connect());
  ASSERT_TRUE(bench.driver->identify());
  const std::size_t before = bench.written().size();
  const auto checked = bench.driver->check();
  ASSERT_TRUE(checked) << checked.error().message;
  EXPECT_EQ(bench.written().substr(before), "D110\r");
}

TEST(Pr6xxDriver, AFamilyMismatchIsRefusedWhenTheDriverIsMade) {
  EXPECT_THROW(Pr6xx(Model::pr730, make_memory_pair("x").first), std::invalid_argument);
  EXPECT_THROW(Pr7xx(Model::pr670, make_memory_pair("x").first), std::invalid_argument);
}

TEST(Pr6xxDriver, D111MustNotNameAnotherModel) {
  MeterOptions other = meter_options(Model::pr670);
  other.wire.d111 = "PR-740";
  Bench contradicted(Model::pr670, {}, fast_remote(), std::move(other));
  auto refused = contradicted.driver->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message,
              HasSubstr("--model pr670 asks for a PR-670, but the meter says it is a 'PR-740'"));
  EXPECT_TRUE(contradicted.written().ends_with("D111\rQ")) << "remote mode left at once";

  MeterOptions unknown = meter_options(Model::pr670);
  unknown.wire.d111 = "PR-810";
  Bench bench(Model::pr670, {}, fast_remote(), std::move(unknown));
  ASSERT_TRUE(bench.driver->connect());
  auto identity = bench.driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->reported_model, "PR-810");
  EXPECT_EQ(identity->model, std::nullopt) << "no model skinspec knows";
  EXPECT_EQ(identity->family, Family::pr6xx);
  EXPECT_THAT(identity->warnings, ::testing::ElementsAre(HasSubstr("unknown-model")));
  EXPECT_TRUE(bench.driver->measure({.integration_ms = 100})) << "measured as the PR-670 it was told it is";
}

TEST(Pr6xxDriver, TheSpectrumMustLieOnD120sGrid) {
  // D120 prints the manuals' example (201 points by 2 nm), the PR-730 measures 401 by 1 nm.
  MeterOptions manual = meter_options(Model::pr730);
  manual.wire.d120_manual = true;
  Bench bench(Model::pr730, {}, fast_remote(), std::move(manual));
  ASSERT_TRUE(bench.driver->connect());
  auto identity = bench.driver->identify();
  ASSERT_TRUE(identity);
  EXPECT_EQ(identity->grid, (Grid{380, 780, 2, 201}));
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, K::protocol) << reading.error().message;
}

// ---- Measuring -------------------------------------------------------------------------------

TEST(Pr6xxDriver, MeasuresTheSourceOnTheMetersGrid) {
  for (const Model model : {Model::pr655, Model::pr670, Model::pr730}) {
    Bench bench(model);
    const auto& row = profile(model);
    ASSERT_TRUE(bench.driver->connect());
    auto reading = bench.driver->measure({.integration_ms = 100});
    ASSERT_TRUE(reading) << row.id << ": " << reading.error().message;
    const Grid grid = *row.simulator_grid;
    ASSERT_EQ(reading->wavelength_nm.size(), static_cast<std::size_t>(grid.points)) << row.id;
    for (int i = 0; i < grid.points; ++i)
      EXPECT_EQ(reading->wavelength_nm[i], grid.first_nm + i * grid.step_nm) << row.id;
    ASSERT_EQ(reading->radiance.size(), bench.scene.radiance.size());
    for (std::size_t i = 0; i < reading->radiance.size(); ++i)
      EXPECT_NEAR(reading->radiance[i], bench.scene.radiance[i], 1e-3 * bench.scene.radiance[i] + 1e-12)
          << row.id << " at " << reading->wavelength_nm[i] << " nm";
    EXPECT_NEAR(reading->x, 0.3127, 0.002) << row.id;  // a white under D65
    EXPECT_NEAR(reading->y, 0.3290, 0.002) << row.id;
    EXPECT_NEAR(reading->luminance, 99, 1) << row.id;  // SU1: cd/m2
    EXPECT_EQ(reading->luminance_units, "cd/m2");
    EXPECT_EQ(reading->attempts, 1);
    EXPECT_EQ(reading->serial_number, row.serial);
  }
}

TEST(Pr6xxDriver, SetupsAreSentOnlyWhenTheyChange) {
  Bench bench(Model::pr670);
  ASSERT_TRUE(bench.driver->connect());
  ASSERT_TRUE(bench.driver->measure({.integration_ms = 100}));
  ASSERT_TRUE(bench.driver->measure({.integration_ms = 100}));
  ASSERT_TRUE(bench.driver->measure({.integration_ms = 200}));
  const std::string written = bench.written();
  auto count = [&](std::string_view what) {
    std::size_t n = 0;
    for (auto at = written.find(what); at != std::string::npos; at = written.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("SE00100\r"), 1u);
  EXPECT_EQ(count("SE00200\r"), 1u);
  EXPECT_EQ(count("SU1\r"), 1u);
  EXPECT_EQ(count("M5\r"), 3u);
}

TEST(Pr6xxDriver, OutOfRangeOptionsAreRejectedBeforeAnyByte) {
  Bench bench(Model::pr670);
  ASSERT_TRUE(bench.driver->connect());
  const std::string before = bench.written();
  auto reading = bench.driver->measure({.integration_ms = 3});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, K::rejected);
  EXPECT_THAT(reading.error().message, HasSubstr("6-6000 ms"));
  EXPECT_FALSE(bench.driver->measure({.integration_ms = 100, .averages = 100}));
  EXPECT_EQ(bench.written(), before);
}

// ---- The error policy -------------------------------------------------------------------------

struct CodeCase {
  int code;
  InstrumentError::Kind kind;
  std::string_view message;
};

const std::vector<CodeCase> kEveryCode = {
    {-1, K::bad_reading, "unstable source: light not constant"},
    {-2, K::bad_reading, "overload"},
    {-3, K::bad_reading, "cannot sync"},
    {-4, K::bad_reading, "adaptive exposure timed out"},
    {-8, K::bad_reading, "too dark"},
    {-9, K::bad_reading, "cannot sync"},
    {-10, K::bad_reading, "cannot sync"},
    {-12, K::bad_reading, "adaptive exposure timed out"},
    {-1000, K::protocol, "refused the measurement"},
    {-1010, K::protocol, "refused the measurement"},
    {-1035, K::protocol, "refused the measurement"},
    {-2000, K::protocol, "has no measurement"},
    {-77, K::bad_reading, "unknown error code -77"},
};

TEST(Pr6xxDriver, EveryMeterErrorCodeBecomesItsKindAndNeverAReading) {
  for (const auto& [model, key] : {std::pair{Model::pr670, "m5"}, std::pair{Model::pr730, "t"}})
    for (const CodeCase& c : kEveryCode) {
      // A PR-7xx's P answering illegal command is a firmware without P: Pr7xxFirmware.
      if (model == Model::pr730 && c.code == pr6xx::kIllegalCommand) continue;
      Bench bench(model, {fmt::format("{}:error={}", key, c.code)});
      ASSERT_TRUE(bench.driver->connect());
      auto reading = bench.driver->measure({.integration_ms = 100});
      ASSERT_FALSE(reading) << profile(model).id << " " << c.code;
      EXPECT_EQ(reading.error().kind, c.kind) << profile(model).id << " " << c.code << ": " << reading.error().message;
      EXPECT_THAT(reading.error().message, HasSubstr(c.message)) << c.code;
      EXPECT_EQ(reading.error().quality_code, c.code);
    }
}

TEST(Pr6xxDriver, ASyncFailureIsMeasuredOnceMoreWithoutSync) {
  for (const auto& [model, key] : {std::pair{Model::pr670, "m5"}, std::pair{Model::pr730, "t"}}) {
    Bench bench(model, {fmt::format("{}:error=-10@1", key)});
    ASSERT_TRUE(bench.driver->connect());
    auto reading = bench.driver->measure({.integration_ms = 100, .sync = MeasureOptions::Sync::automatic});
    ASSERT_TRUE(reading) << reading.error().message;
    EXPECT_EQ(reading->attempts, 2);
    ASSERT_EQ(reading->warnings.size(), 1u);
    EXPECT_THAT(reading->warnings[0], HasSubstr("sync-off:"));
    const std::string written = bench.written();
    EXPECT_LT(written.find("SS1\r"), written.find("SS0\r")) << "sync on, then off";
  }
}

TEST(Pr6xxDriver, ASyncFailureWithoutSyncIsNotRetried) {
  Bench bench(Model::pr670, {"m5:error=-10@1"});
  ASSERT_TRUE(bench.driver->connect());
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, K::bad_reading);
}

TEST(Pr6xxDriver, TooDarkDoublesAFixedExposureWhenAllowed) {
  Bench bench(Model::pr670, {"m5:error=-8@1"});
  ASSERT_TRUE(bench.driver->connect());
  auto reading = bench.driver->measure({.integration_ms = 100, .adjust_integration = true});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->integration_ms, 200);
  EXPECT_THAT(reading->warnings, ::testing::ElementsAre(HasSubstr("exposure: too dark at 100 ms")));
}

TEST(Pr6xxDriver, AnUnstableSourceIsMeasuredOnceMore) {
  Bench bench(Model::pr730, {"t:error=-12@1"});
  ASSERT_TRUE(bench.driver->connect());
  auto reading = bench.driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->attempts, 2);
}

TEST(Pr6xxDriver, AFailedMeasurementAfterAGoodOneGivesNoStaleSpectrum) {
  for (const auto& [model, key] : {std::pair{Model::pr670, "m5"}, std::pair{Model::pr730, "t"}}) {
    Bench bench(model, {fmt::format("{}:error=-8@2+", key)});
    ASSERT_TRUE(bench.driver->connect());
    ASSERT_TRUE(bench.driver->measure({.integration_ms = 100}));
    auto second = bench.driver->measure({.integration_ms = 100});
    ASSERT_FALSE(second) << profile(model).id;
    EXPECT_EQ(second.error().kind, K::bad_reading);
    EXPECT_EQ(second.error().quality_code, -8);
  }
}

// ---- Faults on the wire ----------------------------------------------------------------------

TEST(Pr6xxDriver, ALostPhotoIsSentAgainAfterQ) {
  Bench bench(Model::pr670, {"photo:no-answer@1"});
  ASSERT_TRUE(bench.driver->connect());
  EXPECT_TRUE(bench.written().starts_with("QPHOTOD111\rQPHOTO")) << bench.written();
  EXPECT_TRUE(bench.logged("command PHOTO: remote mode"));
  auto identity = bench.driver->identify();
  ASSERT_TRUE(identity);
  EXPECT_EQ(identity->reported_model, "PR-670");
}

TEST(Pr6xxDriver, AMeterThatNeverAnswersPhotoIsNoContact) {
  Bench bench(Model::pr670, {"photo:no-answer"});
  auto connected = bench.driver->connect();
  ASSERT_FALSE(connected);
  EXPECT_EQ(connected.error().kind, K::no_contact);
  EXPECT_THAT(connected.error().message, HasSubstr("Power Saving off"));
}

TEST(Pr6xxDriver, ABannerGluedToTheNextReplyIsTakenAsRemoteMode) {
  Bench bench(Model::pr730, {"photo:glue"});
  ASSERT_TRUE(bench.driver->connect());
  auto identity = bench.driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->reported_model, "PR-730/735");
  EXPECT_THAT(identity->warnings, ::testing::ElementsAre(HasSubstr("banner-glued")));
  EXPECT_EQ(bench.driver->identify()->warnings, identity->warnings) << "the same once more";
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 401u);
}

TEST(Pr6xxDriver, ATruncatedSpectrumIsAProtocolErrorNotAReading) {
  for (const auto& [model, faults] :
       {std::pair{Model::pr670, std::vector<std::string>{"m5:truncate=300", "d5:truncate=300"}},
        std::pair{Model::pr730, std::vector<std::string>{"d5:truncate=300"}}}) {
    Bench bench(model, faults);
    ASSERT_TRUE(bench.driver->connect());
    auto reading = bench.driver->measure({.integration_ms = 100});
    ASSERT_FALSE(reading) << profile(model).id;
    EXPECT_EQ(reading.error().kind, K::protocol) << reading.error().message;
  }
}

TEST(Pr6xxDriver, ATruncatedM5IsReadAgainWithD5) {
  Bench bench(Model::pr670, {"m5:truncate=300"});
  ASSERT_TRUE(bench.driver->connect());
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 201u);
  EXPECT_EQ(reading->attempts, 1) << "the meter measured once";
}

TEST(Pr6xxDriver, PacingKeepsEveryByteOfAMeterThatLosesFastOnes) {
  // The meter loses a byte that follows the one before within 20 ms.
  RemoteOptions unpaced = fast_remote();
  Bench lossy(Model::pr670, {"*:fast-loss=20"}, unpaced);
  auto refused = lossy.driver->connect();
  ASSERT_FALSE(refused) << "whole strings lose all but their first byte";
  EXPECT_EQ(refused.error().kind, K::no_contact);

  RemoteOptions paced = fast_remote();
  paced.pacing = std::nullopt;  // the profile's 50 ms
  Bench bench(Model::pr670, {"*:fast-loss=20"}, paced);
  auto connected = bench.driver->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 201u);
}

TEST(Pr6xxDriver, ACancelledM5IsDrainedBeforeTheNextMeasurement) {
  MeterOptions meter = meter_options(Model::pr670);
  meter.time_scale = 1;
  RemoteOptions options = fast_remote();
  options.timing.reply = 3s;
  options.timing.line_bytes_per_second = 960;
  options.timing.measurement_overhead = 3s;  // the meter's own overhead, unscaled
  Bench bench(Model::pr670, {}, options, std::move(meter));
  ASSERT_TRUE(bench.driver->connect());
  std::atomic<bool> returned{false};
  std::thread canceller([&] {
    while (bench.written().find("M5\r") == std::string::npos && !returned) std::this_thread::sleep_for(5ms);
    std::this_thread::sleep_for(100ms);
    bench.driver->cancel();
  });
  auto cancelled = bench.driver->measure({.integration_ms = 1000});
  returned = true;
  canceller.join();
  ASSERT_FALSE(cancelled);
  EXPECT_EQ(cancelled.error().kind, K::cancelled);
  // The cancelled M5's spectrum arrives late; it must not be taken for a reply to what follows.
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 201u);
  EXPECT_EQ(reading->integration_ms, 100);
}

// A cancel that lands while a spectrum streams in: the meter sends the rest of it all the same.
// Neither the idle check that follows (D110) nor the next measurement may take it for its own
// reply. The PR-670's spectrum is M5's reply; the PR-730's comes after T, P and V, to D5.
TEST(Pr6xxDriver, TheRestOfASpectrumACancelCutShortIsNotTakenForTheNextReply) {
  for (const Model model : {Model::pr670, Model::pr730}) {
    MeterOptions meter = meter_options(model);
    meter.time_scale = 0.25;  // the spectrum streams for about 1 s (PR-670) or 1.7 s (PR-730)
    RemoteOptions options = fast_remote();
    options.timing.reply = 3s;
    options.timing.line_bytes_per_second = 960;
    options.timing.measurement_overhead = 3s;
    Bench bench(model, {}, options, std::move(meter));
    ASSERT_TRUE(bench.driver->connect());
    const std::string spectrum_command = profile(model).family == Family::pr6xx ? "M5\r" : "D5\r";
    std::atomic<bool> returned{false};
    std::thread canceller([&] {
      while (bench.written().find(spectrum_command) == std::string::npos && !returned) std::this_thread::sleep_for(1ms);
      // Once the spectrum's first bytes are in.
      const std::uint64_t before = bench.driver->replies_received();
      while (bench.driver->replies_received() == before && !returned) std::this_thread::sleep_for(1ms);
      std::this_thread::sleep_for(100ms);
      bench.driver->cancel();
    });
    auto cancelled = bench.driver->measure({.integration_ms = 100});
    returned = true;
    canceller.join();
    ASSERT_FALSE(cancelled) << profile(model).id;
    ASSERT_EQ(cancelled.error().kind, K::cancelled) << profile(model).id << ": " << cancelled.error().message;
    const auto checked = bench.driver->check();
    EXPECT_TRUE(checked) << profile(model).id << ": " << checked.error().message;
    auto reading = bench.driver->measure({.integration_ms = 100});
    ASSERT_TRUE(reading) << profile(model).id << ": " << reading.error().message;
    EXPECT_EQ(reading->radiance.size(), static_cast<std::size_t>(profile(model).simulator_grid->points));
  }
}

// ---- Leaving remote mode ---------------------------------------------------------------------

TEST(Pr6xxDriver, DisconnectAndDestructionSendQ) {
  {
    Bench bench(Model::pr670);
    ASSERT_TRUE(bench.driver->connect());
    EXPECT_FALSE(bench.logged("command Q: remote mode left"));
    bench.driver->disconnect();
    EXPECT_TRUE(bench.written().ends_with("Q"));
    bench.rig.wait_for_end(200ms);
    EXPECT_TRUE(bench.logged("command Q: remote mode left"));
  }
  {
    Bench bench(Model::pr730);
    ASSERT_TRUE(bench.driver->connect());
    ASSERT_TRUE(bench.driver->measure({.integration_ms = 100}));
    bench.driver.reset();
    EXPECT_TRUE(bench.written().ends_with("Q"));
    bench.rig.wait_for_end(200ms);
    EXPECT_TRUE(bench.logged("command Q: remote mode left"));
  }
}

TEST(Pr6xxDriver, APr7xxMeasurementCancelledMidwayIsAborted) {
  MeterOptions meter = meter_options(Model::pr730);
  meter.time_scale = 1;  // a 2 x 120 s measurement really takes that long
  RemoteOptions options = fast_remote();
  options.timing.reply = 3s;  // the meter's own reply times and line rate, unscaled
  options.timing.line_bytes_per_second = 960;
  Bench bench(Model::pr730, {}, options, std::move(meter));
  ASSERT_TRUE(bench.driver->connect());
  std::atomic<bool> returned{false};
  std::thread canceller([&] {
    // Cancel once the meter has been polled while busy.
    while (bench.written().find("P\r") == std::string::npos && !returned) std::this_thread::sleep_for(5ms);
    std::this_thread::sleep_for(50ms);
    bench.driver->cancel();
  });
  const auto start = std::chrono::steady_clock::now();
  auto reading = bench.driver->measure({.integration_ms = 120000});
  returned = true;
  canceller.join();
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, K::cancelled) << reading.error().message;
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
  const std::string written = bench.written();
  EXPECT_TRUE(written.ends_with("A\r")) << written.substr(written.size() > 40 ? written.size() - 40 : 0);
  EXPECT_EQ(written.find('Q', 1), std::string::npos) << "still remote after an abort";
}

// ---- Firmware generations -------------------------------------------------------------------

std::size_t occurrences(const std::string& text, std::string_view what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::size_t warnings_with(const std::vector<std::string>& warnings, std::string_view code) {
  return static_cast<std::size_t>(
      std::ranges::count_if(warnings, [&](const std::string& w) { return w.starts_with(code); }));
}

MeterOptions with_firmware(Model model, std::string firmware) {
  MeterOptions meter = meter_options(model);
  meter.firmware = std::move(firmware);
  return meter;
}

// A 2009 PR-730 (M5 only) at `time_scale`, its replies read at the link's own pace with room
// for an M5's measurement: what the M5 tests below share.
std::unique_ptr<Bench> m5_only_pr730(double time_scale) {
  MeterOptions meter = with_firmware(Model::pr730, "m730");
  meter.time_scale = time_scale;
  RemoteOptions options = fast_remote();
  options.timing.reply = 3s;
  options.timing.line_bytes_per_second = 960;
  options.timing.measurement_overhead = 3s;
  return std::make_unique<Bench>(Model::pr730, std::vector<std::string>{}, options, std::move(meter));
}

// The 2009 PR-730/735 firmware knows neither T nor SS: the driver measures with M5 and syncs
// with SQ from the first refusal on, and says each once, on the reading where it was found and
// on the instrument.
TEST(Pr7xxFirmware, APr730WithoutTMeasuresWithM5AndWarnsOnce) {
  Bench bench(Model::pr730, {}, fast_remote(), with_firmware(Model::pr730, "m730"));
  ASSERT_TRUE(bench.driver->connect());
  ASSERT_TRUE(bench.driver->identify());
  auto first = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_EQ(first->radiance.size(), 401u);
  EXPECT_EQ(warnings_with(first->warnings, "m5-fallback"), 1u) << ::testing::PrintToString(first->warnings);
  EXPECT_EQ(warnings_with(first->warnings, "sync-command"), 1u) << ::testing::PrintToString(first->warnings);
  auto second = bench.driver->measure({.integration_ms = 200});
  ASSERT_TRUE(second) << second.error().message;
  EXPECT_THAT(second->warnings, ::testing::IsEmpty()) << "said once";
  const auto said = bench.driver->firmware_warnings();
  EXPECT_EQ(warnings_with(said, "m5-fallback"), 1u) << ::testing::PrintToString(said);
  EXPECT_EQ(said.size(), 2u) << ::testing::PrintToString(said);
  const std::string written = bench.written();
  EXPECT_EQ(occurrences(written, "T\r"), 1u) << "T is tried once per connection";
  EXPECT_EQ(occurrences(written, "M5\r"), 2u);
  EXPECT_EQ(occurrences(written, "P\r"), 0u);
  EXPECT_NE(written.find("SQ0\r"), std::string::npos);
  EXPECT_EQ(bench.rig.meter().measurements(), 2u);
  // A new connection finds out again: the meter on the port may have been swapped.
  bench.driver->disconnect();
}

// The same generation after a new connection, from the identity the daemon shows.
TEST(Pr7xxFirmware, TheFallbackIsOnTheIdentityOnceFound) {
  Bench bench(Model::pr730, {}, fast_remote(), with_firmware(Model::pr730, "m730"));
  ASSERT_TRUE(bench.driver->connect());
  auto before = bench.driver->identify();
  ASSERT_TRUE(before);
  EXPECT_EQ(warnings_with(before->warnings, "m5-fallback"), 0u);
  ASSERT_TRUE(bench.driver->measure({.integration_ms = 100}));
  auto after = bench.driver->identify();
  ASSERT_TRUE(after);
  EXPECT_EQ(warnings_with(after->warnings, "m5-fallback"), 1u) << ::testing::PrintToString(after->warnings);
}

// A PR-740 knows T, P, A and V: it is triggered, polled and read with D5, never sent M5, and a
// cancel aborts its measurement with A.
TEST(Pr7xxFirmware, APr740WithTStillTriggersPollsAndAborts) {
  for (const std::string firmware : {"m7xx", "m740"}) {
    Bench bench(Model::pr740, {}, fast_remote(), with_firmware(Model::pr740, firmware));
    ASSERT_TRUE(bench.driver->connect());
    auto reading = bench.driver->measure({.integration_ms = 100});
    ASSERT_TRUE(reading) << reading.error().message;
    EXPECT_THAT(reading->warnings, ::testing::IsEmpty());
    EXPECT_THAT(bench.driver->firmware_warnings(), ::testing::IsEmpty());
    const std::string written = bench.written();
    EXPECT_NE(written.find("T\rP\rV\rD5\r"), std::string::npos) << written;
    EXPECT_EQ(written.find("M5\r"), std::string::npos);
    EXPECT_NE(written.find("SS0\r"), std::string::npos);
  }
  MeterOptions meter = with_firmware(Model::pr740, "m740");
  meter.time_scale = 1;
  RemoteOptions options = fast_remote();
  options.timing.reply = 3s;
  options.timing.line_bytes_per_second = 960;
  Bench bench(Model::pr740, {}, options, std::move(meter));
  ASSERT_TRUE(bench.driver->connect());
  std::atomic<bool> returned{false};
  std::thread canceller([&] {
    while (bench.written().find("P\r") == std::string::npos && !returned) std::this_thread::sleep_for(5ms);
    bench.driver->cancel();
  });
  auto cancelled = bench.driver->measure({.integration_ms = 60000});
  returned = true;
  canceller.join();
  ASSERT_FALSE(cancelled);
  EXPECT_EQ(cancelled.error().kind, K::cancelled);
  EXPECT_TRUE(bench.written().ends_with("A\r")) << bench.written();
}

// An M5 cannot be stopped on the wire: a cancel returns at once, the meter measures on, and its
// reading is discarded when it arrives, before the next measurement's commands.
TEST(Pr7xxFirmware, ACancelledM5RunsOnAndItsReadingIsDiscarded) {
  const auto owned = m5_only_pr730(0.2);
  Bench& bench = *owned;
  ASSERT_TRUE(bench.driver->connect());
  auto found = bench.driver->measure({.integration_ms = 100});  // finds out: M5 from now on
  ASSERT_TRUE(found) << found.error().message << "\n"
                     << bench.written() << "\n"
                     << ::testing::PrintToString(bench.rig.log());
  std::atomic<bool> returned{false};
  std::thread canceller([&] {
    while (occurrences(bench.written(), "M5\r") < 2 && !returned) std::this_thread::sleep_for(5ms);
    std::this_thread::sleep_for(50ms);
    bench.driver->cancel();
  });
  const auto start = std::chrono::steady_clock::now();
  auto cancelled = bench.driver->measure({.integration_ms = 2000});  // 0.9 s at this time scale
  returned = true;
  canceller.join();
  ASSERT_FALSE(cancelled);
  EXPECT_EQ(cancelled.error().kind, K::cancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 600ms) << "the cancel does not wait for the measurement";
  EXPECT_EQ(bench.written().find("A\r"), std::string::npos) << "no abort on this firmware";
  auto next = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(next) << next.error().message;
  EXPECT_EQ(next->integration_ms, 100);
  EXPECT_EQ(next->radiance.size(), 401u);
}

// At the meter's own pace the LF of T's refusal comes after its CR was taken as the line's end:
// it is not the first byte of M5's reply, which would then be cut at the measurement's pause.
TEST(Pr7xxFirmware, AnM5AtTheMetersOwnPaceIsReadWhole) {
  const auto owned = m5_only_pr730(1);
  Bench& bench = *owned;
  ASSERT_TRUE(bench.driver->connect());
  auto reading = bench.driver->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message << "\n" << bench.written();
  EXPECT_EQ(bench.written().find("D5\r"), std::string::npos) << "M5's own reply was whole";
}

// A setup the firmware does not know is done without where that changes nothing the reading
// depends on (SH0, SN01, SU), and refused where it would (SH1, SN02).
TEST(Pr7xxFirmware, UnknownSetupsAreDoneWithoutOnlyWhereHarmless) {
  {
    Bench bench(Model::pr730, {"sh:error=-1000", "su:error=-1000"}, fast_remote());
    ASSERT_TRUE(bench.driver->connect());
    auto reading = bench.driver->measure({.integration_ms = 100});
    ASSERT_TRUE(reading) << reading.error().message;
    EXPECT_EQ(warnings_with(reading->warnings, "no-sensitivity"), 1u) << ::testing::PrintToString(reading->warnings);
    EXPECT_EQ(warnings_with(reading->warnings, "no-units"), 1u);
    EXPECT_EQ(reading->luminance_units, "as set on the meter");
  }
  {
    Bench bench(Model::pr730, {"sn:error=-1000"}, fast_remote());
    ASSERT_TRUE(bench.driver->connect());
    auto refused = bench.driver->measure({.integration_ms = 100, .averages = 2});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, K::rejected) << refused.error().message;
  }
}

// ---- D13: the exposure an adaptive measurement used ------------------------------------------

// The exposure the simulator logged for its last measurement ("measured '...': N ms exposure").
std::optional<int> exposure_logged(const MeterRig& rig) {
  const auto log = rig.log();
  for (auto line = log.rbegin(); line != log.rend(); ++line) {
    const auto end = line->find(" ms exposure");
    if (!line->starts_with("measured '") || end == std::string::npos) continue;
    const auto start = line->rfind(' ', end - 1) + 1;
    return std::stoi(line->substr(start, end - start));
  }
  return std::nullopt;
}

// After an adaptive measurement both families ask D13 for the exposure the meter chose, and the
// reading keeps it; after a fixed one nothing is asked, the exposure being the one set.
TEST(Pr6xxExposureUsed, AnAdaptiveMeasurementKeepsTheExposureTheMeterChose) {
  for (const Model model : {Model::pr670, Model::pr730}) {
    Bench bench(model);
    ASSERT_TRUE(bench.driver->connect());
    auto adaptive = bench.driver->measure({});
    ASSERT_TRUE(adaptive) << profile(model).id << ": " << adaptive.error().message;
    const auto logged = exposure_logged(bench.rig);
    ASSERT_TRUE(logged) << profile(model).id;
    EXPECT_EQ(adaptive->integration_ms, 0);
    EXPECT_EQ(adaptive->exposure_used_ms, logged) << profile(model).id;
    EXPECT_THAT(adaptive->warnings, ::testing::IsEmpty());
    EXPECT_EQ(occurrences(bench.written(), "D13\r"), 1u);
    auto fixed = bench.driver->measure({.integration_ms = 100});
    ASSERT_TRUE(fixed) << fixed.error().message;
    EXPECT_EQ(fixed->exposure_used_ms, std::nullopt);
    EXPECT_EQ(occurrences(bench.written(), "D13\r"), 1u) << "not asked after a fixed exposure";
  }
}

// A firmware that does not know D13 (illegal command) still measures: the exposure is unknown,
// said once, and D13 is not sent again on the connection. Another refusal (no data) leaves that
// reading's exposure unknown and asks again next time.
TEST(Pr6xxExposureUsed, ARefusedD13IsAnUnknownExposureNotAFailure) {
  {
    Bench bench(Model::pr730, {"d13:error=-1000"});
    ASSERT_TRUE(bench.driver->connect());
    auto first = bench.driver->measure({});
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_EQ(first->exposure_used_ms, std::nullopt);
    EXPECT_EQ(warnings_with(first->warnings, "no-exposure-report"), 1u) << ::testing::PrintToString(first->warnings);
    auto second = bench.driver->measure({});
    ASSERT_TRUE(second) << second.error().message;
    EXPECT_EQ(second->exposure_used_ms, std::nullopt);
    EXPECT_THAT(second->warnings, ::testing::IsEmpty()) << "said once";
    EXPECT_EQ(warnings_with(bench.driver->firmware_warnings(), "no-exposure-report"), 1u);
    EXPECT_EQ(occurrences(bench.written(), "D13\r"), 1u) << "not asked again on this connection";
  }
  {
    Bench bench(Model::pr670, {"d13:error=-2000@1"});
    ASSERT_TRUE(bench.driver->connect());
    auto first = bench.driver->measure({});
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_EQ(first->exposure_used_ms, std::nullopt);
    EXPECT_THAT(first->warnings, ::testing::IsEmpty());
    auto second = bench.driver->measure({});
    ASSERT_TRUE(second) << second.error().message;
    EXPECT_EQ(second->exposure_used_ms, exposure_logged(bench.rig));
  }
}

// The apertures D117 lists, by name, for whoever offers them; none on a model without.
TEST(Pr6xxDriver, TheAperturesAreTheMetersOwnNames) {
  Bench pr670(Model::pr670);
  ASSERT_TRUE(pr670.driver->connect());
  auto listed = pr670.driver->apertures();
  ASSERT_TRUE(listed) << listed.error().message;
  EXPECT_THAT(*listed, ::testing::ElementsAre("1 deg", "1/2 deg", "1/4 deg", "1/8 deg"));
  ASSERT_TRUE(pr670.driver->measure({.integration_ms = 100, .aperture = "1/2 DEG"}));
  EXPECT_EQ(occurrences(pr670.written(), "D117\r"), 1u) << "read once per connection";
  Bench pr655(Model::pr655);
  ASSERT_TRUE(pr655.driver->connect());
  auto none = pr655.driver->apertures();
  ASSERT_TRUE(none);
  EXPECT_THAT(*none, ::testing::IsEmpty());
  EXPECT_EQ(occurrences(pr655.written(), "D117\r"), 0u);
}

// ---- No hang: every wait sized to its command ------------------------------------------------

// 120 s exposures averaged twice take 8 minutes on the meter (here a hundredth of it): polled
// until done within the deadline sized to them, never timed out.
TEST(Pr7xxDeadlines, ALongExposureAveragedTwiceFinishes) {
  MeterOptions meter = meter_options(Model::pr730);
  meter.time_scale = 0.01;
  meter.sensor.full_scale = 1e4;  // a dim source: 120 s fills the detector halfway
  RemoteOptions options = fast_remote();
  options.timing.reply = 2s;
  options.timing.measurement_overhead = 1s;
  options.timing.poll_interval = 100ms;
  options.timing.line_bytes_per_second = 960;  // the meter's own line rate, unscaled
  Bench bench(Model::pr730, {}, options, std::move(meter));
  ASSERT_TRUE(bench.driver->connect());
  const MeasureOptions two_long{.integration_ms = 120000, .averages = 2};
  EXPECT_GT(bench.driver->reading_time(two_long), 481s) << "two dark and two light exposures of 120 s, and more";
  auto reading = bench.driver->measure(two_long);
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->averages, 2);
  EXPECT_NE(bench.written().find("SN02\r"), std::string::npos);
  EXPECT_NE(bench.written().find("SE120000\r"), std::string::npos);
}

// ---- Q alone: a stop inside a paced command -------------------------------------------------

// How the test stops the driver while `command` goes out: a cancel and the next call, a cancel
// and a disconnect (what skinspecd's stop does), or a disconnect alone.
enum class Stop { cancel_then_continue, cancel_and_disconnect, disconnect };

std::string_view to_string(Stop stop) {
  switch (stop) {
    case Stop::cancel_then_continue:
      return "cancel";
    case Stop::cancel_and_disconnect:
      return "cancel and disconnect";
    case Stop::disconnect:
      return "disconnect";
  }
  return "?";
}

// Paced as a real meter's link is, slowly enough for the watcher to land between two bytes.
RemoteOptions paced() {
  RemoteOptions options = fast_remote();
  options.pacing = 8ms;
  return options;
}

// Runs `call` on the bench's driver and stops it with `stop` once the first `bytes` bytes of
// `command` (its first occurrence after what was written before) are on the wire.
void stop_inside(Bench& bench, const std::string& command, std::size_t bytes, Stop stop,
                 const std::function<void()>& call) {
  const std::size_t mark = bench.written().size();
  std::atomic<bool> done{false};
  std::thread stopper([&] {
    const std::string prefix = command.substr(0, bytes);
    for (;;) {
      const std::string written = bench.written();
      const auto at = written.find(command.substr(0, 2), mark);
      if (at != std::string::npos && written.size() >= at + bytes && written.compare(at, bytes, prefix) == 0) break;
      if (done) return;
      std::this_thread::sleep_for(200us);
    }
    if (stop != Stop::disconnect) bench.driver->cancel();
    if (stop != Stop::cancel_then_continue) bench.driver->disconnect();
  });
  call();
  done = true;
  stopper.join();
}

// The meter's own account: every command it took was one it knows (no "D11Q"), no setup it
// took was other than the driver meant, and it ended in local mode after a Q of its own.
void expect_q_alone(Bench& bench, const std::string& where) {
  bench.driver->disconnect();
  bench.rig.wait_for_end(100ms);
  EXPECT_THAT(bench.rig.meter().problems(), ::testing::IsEmpty()) << where;
  EXPECT_TRUE(bench.logged("command Q: remote mode left")) << where << "\n" << bench.written();
  EXPECT_EQ(bench.rig.meter().mode(), simulator::SimulatedMeter::Mode::local) << where;
  const auto log = bench.rig.log();
  EXPECT_FALSE(std::ranges::any_of(log, [](const std::string& l) { return l.find("refused") != std::string::npos; }))
      << where;
}

TEST(Pr6xxQuitAlone, AStopAtEveryByteOfD110LeavesQAlone) {
  const std::string d110 = "D110\r";
  for (const Stop stop : {Stop::cancel_then_continue, Stop::cancel_and_disconnect, Stop::disconnect})
    for (std::size_t bytes = 1; bytes <= d110.size(); ++bytes) {
      const std::string where = fmt::format("{} after {} bytes of D110", to_string(stop), bytes);
      Bench bench(Model::pr670, {}, paced());
      ASSERT_TRUE(bench.driver->connect()) << where;
      ASSERT_TRUE(bench.driver->identify()) << where;
      stop_inside(bench, d110, bytes, stop, [&] { (void)bench.driver->check(); });
      if (stop == Stop::cancel_then_continue) {
        EXPECT_TRUE(bench.driver->check()) << where;
      }
      expect_q_alone(bench, where);
    }
}

TEST(Pr6xxQuitAlone, AStopAtEveryByteOfASetupLeavesQAlone) {
  const std::string setup = pr6xx::format_exposure(123);  // "SE00123\r"
  for (const Model model : {Model::pr670, Model::pr730})
    for (const Stop stop : {Stop::cancel_then_continue, Stop::cancel_and_disconnect})
      for (std::size_t bytes = 1; bytes <= setup.size(); ++bytes) {
        const std::string where = fmt::format("{}: {} after {} bytes of {}", profile(model).name, to_string(stop),
                                              bytes, setup.substr(0, setup.size() - 1));
        Bench bench(model, {}, paced());
        ASSERT_TRUE(bench.driver->connect()) << where;
        stop_inside(bench, setup, bytes, stop, [&] { (void)bench.driver->measure({.integration_ms = 123}); });
        if (stop == Stop::cancel_then_continue) {
          auto next = bench.driver->measure({.integration_ms = 123});
          EXPECT_TRUE(next) << where << ": " << next.error().message;
        }
        expect_q_alone(bench, where);
      }
}
}  // namespace
}  // namespace skinspec::drivers
