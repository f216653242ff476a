// The measuring options beyond exposure and averages, on every family that has them and
// refused by those that do not: a sync frequency given by the user, extended sensitivity,
// apertures by the names the meter lists, and a PR-7xx still busy with a measurement that was
// never aborted. Against the simulated meters in process.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include <fmt/format.h>

#include "support/meter_bench.hpp"

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::meter_options;
using Bench = testing::InstrumentBench;
using K = InstrumentError::Kind;
using Sync = MeasureOptions::Sync;

ModelChoice forced(Model model) { return ModelChoice{model}; }

std::size_t count(std::string_view text, std::string_view what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string_view::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// Whether `first` is written, and `second` after it.
bool in_order(std::string_view text, std::string_view first, std::string_view second) {
  const auto at = text.find(first);
  return at != std::string_view::npos && text.find(second, at + first.size()) != std::string_view::npos;
}

// The bytes written since `mark` (what was written when it was taken).
std::string since(const Bench& bench, std::size_t mark) { return bench.written().substr(mark); }

// ---- Sync to a frequency the user gives -------------------------------------------------------

TEST(MeterSetup, AUserSyncFrequencyIsSs3WithSk) {
  for (const Model model : {Model::pr670, Model::pr730}) {
    Bench bench(model, forced(model));
    ASSERT_TRUE(bench.instrument->connect());
    const MeasureOptions options{.integration_ms = 100, .sync = Sync::frequency, .sync_hz = 60};
    auto reading = bench.instrument->measure(options);
    ASSERT_TRUE(reading) << profile(model).id << ": " << reading.error().message;
    EXPECT_EQ(reading->sync, "60 Hz (user)");
    EXPECT_TRUE(reading->warnings.empty());
    ASSERT_TRUE(bench.instrument->measure(options));
    const std::string written = bench.written();
    EXPECT_TRUE(in_order(written, "SS3\r", "SK060\r")) << written;
    EXPECT_EQ(count(written, "SS3\r"), 1u) << "sent once per connection";
    EXPECT_EQ(count(written, "SK060\r"), 1u);
    EXPECT_EQ(count(written, "F\r"), 0u) << "no flicker measurement for a frequency given";
  }
}

TEST(MeterSetup, AUserSyncTheLightDoesNotAllowIsMeasuredAgainWithout) {
  // A steady lamp: the meter cannot sync (-3).
  Bench bench(Model::pr670, forced(Model::pr670), {}, {}, testing::fast_options(), 0);
  ASSERT_TRUE(bench.instrument->connect());
  auto reading = bench.instrument->measure({.integration_ms = 100, .sync = Sync::frequency, .sync_hz = 50});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->attempts, 2);
  EXPECT_THAT(reading->warnings, ::testing::ElementsAre(HasSubstr("sync-off: the meter could not sync (-3)")));
  EXPECT_EQ(reading->sync, "off");
  EXPECT_TRUE(in_order(bench.written(), "SK050\r", "SS0\r"));
}

TEST(MeterSetup, ASyncFrequencyOutsideTheModelsRangeIsRefusedBeforeAnyByte) {
  Bench bench(Model::pr670, forced(Model::pr670));
  ASSERT_TRUE(bench.instrument->connect());
  const std::string before = bench.written();
  for (const double hz : {10.0, 401.0, 59.5}) {
    auto refused = bench.instrument->measure({.integration_ms = 100, .sync = Sync::frequency, .sync_hz = hz});
    ASSERT_FALSE(refused) << hz;
    EXPECT_EQ(refused.error().kind, K::rejected);
    EXPECT_THAT(refused.error().message, HasSubstr("the PR-670 syncs to whole hertz from 20 to 400 Hz")) << hz;
  }
  EXPECT_EQ(bench.written(), before);
}

TEST(MeterSetup, ThePr650SyncsToAFrequencyInItsSetupAndHasNoNewerMetersOptions) {
  Bench bench(Model::pr650, forced(Model::pr650));
  ASSERT_TRUE(bench.instrument->connect());
  auto reading = bench.instrument->measure({.integration_ms = 100, .sync = Sync::frequency, .sync_hz = 50});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->sync, "50 Hz (user)");
  EXPECT_THAT(bench.written(), HasSubstr("s01,,,,50,100,01,1\n"));

  const std::string before = bench.written();
  for (const auto& [options, message] :
       {std::pair{MeasureOptions{.sync = Sync::frequency, .sync_hz = 300}, "the PR-650 syncs to 40-250 Hz"},
        std::pair{MeasureOptions{.extended_sensitivity = true}, "the PR-650 has no extended sensitivity"},
        std::pair{MeasureOptions{.aperture = "1/2 deg"}, "the PR-650 has no apertures to choose ('1/2 deg')"}}) {
    auto refused = bench.instrument->measure(options);
    ASSERT_FALSE(refused) << message;
    EXPECT_EQ(refused.error().kind, K::rejected);
    EXPECT_THAT(refused.error().message, HasSubstr(message));
  }
  EXPECT_EQ(bench.written(), before);
}

// ---- Extended sensitivity ------------------------------------------------------------------

// A meter whose detector an exposure of `longest_ms` fills to 80 %: no overload up to it, and
// no weak light down to a fiftieth of it.
simulator::MeterOptions filled_at(Model model, int longest_ms, std::vector<std::string> faults = {}) {
  simulator::MeterOptions meter = meter_options(model, std::move(faults));
  meter.sensor.full_scale = std::ranges::max(testing::white_on(model).radiance) * longest_ms * 1.25;
  return meter;
}

TEST(MeterSetup, ExtendedSensitivityComesBeforeTheLongerExposureItAllows) {
  for (const auto& [model, extended_ms] : {std::pair{Model::pr670, 20000}, std::pair{Model::pr730, 200000}}) {
    Bench bench(model, forced(model), filled_at(model, extended_ms));
    ASSERT_TRUE(bench.instrument->connect());
    auto refused = bench.instrument->measure({.integration_ms = extended_ms});
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, K::rejected);
    auto reading = bench.instrument->measure({.integration_ms = extended_ms, .extended_sensitivity = true});
    ASSERT_TRUE(reading) << profile(model).id << ": " << reading.error().message;
    EXPECT_EQ(reading->integration_ms, extended_ms);
    const std::size_t mark = bench.written().size();
    auto normal = bench.instrument->measure({.integration_ms = 5000});
    ASSERT_TRUE(normal) << normal.error().message;
    EXPECT_TRUE(in_order(since(bench, mark), "SH0\r", "SE05000\r")) << since(bench, mark);
    EXPECT_TRUE(in_order(bench.written(), "SH1\r", fmt::format("SE{}\r", extended_ms)));
  }
}

TEST(MeterSetup, AModelWithoutSensitivityOrAperturesRefusesThemBeforeAnyByte) {
  Bench bench(Model::pr655, forced(Model::pr655));
  ASSERT_TRUE(bench.instrument->connect());
  ASSERT_TRUE(bench.instrument->measure({.integration_ms = 100}));
  EXPECT_EQ(count(bench.written(), "SH"), 0u) << "never sent to a model without SH";
  const std::string before = bench.written();
  auto no_sensitivity = bench.instrument->measure({.integration_ms = 100, .extended_sensitivity = true});
  ASSERT_FALSE(no_sensitivity);
  EXPECT_EQ(no_sensitivity.error().kind, K::rejected);
  EXPECT_THAT(no_sensitivity.error().message, HasSubstr("the PR-655 has no extended sensitivity"));
  auto no_aperture = bench.instrument->measure({.integration_ms = 100, .aperture = "1 deg"});
  ASSERT_FALSE(no_aperture);
  EXPECT_EQ(no_aperture.error().kind, K::rejected);
  EXPECT_THAT(no_aperture.error().message, HasSubstr("the PR-655 has no apertures to choose ('1 deg')"));
  EXPECT_EQ(bench.written(), before);
}

// ---- Apertures --------------------------------------------------------------------------------

TEST(MeterSetup, AnApertureIsChosenByTheNameD117Lists) {
  for (const Model model : {Model::pr670, Model::pr740}) {
    Bench bench(model, forced(model));
    ASSERT_TRUE(bench.instrument->connect());
    auto reading = bench.instrument->measure({.integration_ms = 100, .aperture = "1/4 deg"});
    ASSERT_TRUE(reading) << profile(model).id << ": " << reading.error().message;
    ASSERT_TRUE(bench.instrument->measure({.integration_ms = 100, .aperture = "1/2DEG"}));
    const std::string written = bench.written();
    EXPECT_TRUE(in_order(written, "D117\r", "SF2\r")) << written;
    EXPECT_TRUE(in_order(written, "SF2\r", "SF1\r")) << "case and blanks do not matter";
    EXPECT_EQ(count(written, "D117\r"), 1u) << "listed once per connection";

    auto unknown = bench.instrument->measure({.integration_ms = 100, .aperture = "2 deg"});
    ASSERT_FALSE(unknown);
    EXPECT_EQ(unknown.error().kind, K::rejected);
    EXPECT_THAT(unknown.error().message,
                HasSubstr(fmt::format("aperture '2 deg': the {} lists '1 deg', '1/2 deg', '1/4 deg', '1/8 deg'",
                                      profile(model).name)));
  }
}

// ---- A PR-7xx busy with another measurement --------------------------------------------------

// A PR-730 measuring for real (a twentieth of real time) whose abort is lost: a cancelled
// measurement goes on in the meter, and the next commands are answered busy.
struct BusyBench {
  static constexpr int kExposureMs = 5000;
  BusyBench() : bench(Model::pr730, forced(Model::pr730), meter(), {}, options()) {}
  static simulator::MeterOptions meter() {
    simulator::MeterOptions m = filled_at(Model::pr730, kExposureMs, {"a:no-answer"});
    m.time_scale = 0.05;
    return m;
  }
  static InstrumentOptions options() {
    InstrumentOptions o = testing::fast_options();
    o.remote.timing.line_bytes_per_second = 4800;  // the meter's 960 at a twentieth of real time, with room
    o.remote.timing.reply = 150ms;                 // the lost abort's wait, well within the measurement
    return o;
  }
  // A 5000 ms measurement (about 0.5 s here), cancelled once it has been polled.
  void leave_measuring() {
    std::atomic<bool> returned{false};
    const std::size_t mark = bench.written().size();
    std::thread canceller([&] {
      while (since(bench, mark).find("P\r") == std::string::npos && !returned) std::this_thread::sleep_for(2ms);
      bench.instrument->cancel();
    });
    auto cancelled = bench.instrument->measure({.integration_ms = kExposureMs});
    returned = true;
    canceller.join();
    ASSERT_FALSE(cancelled);
    EXPECT_EQ(cancelled.error().kind, K::cancelled) << cancelled.error().message;
    EXPECT_TRUE(bench.written().ends_with("A\r")) << "the abort the meter does not answer";
  }
  Bench bench;
};

TEST(MeterSetup, APr7xxBusyWithAMeasurementIsPolledUntilDoneThenAskedAgain) {
  BusyBench busy;
  ASSERT_TRUE(busy.bench.instrument->connect());
  ASSERT_NO_FATAL_FAILURE(busy.leave_measuring());
  // A changed exposure: SE is answered busy, P followed until done, SE sent again.
  std::size_t mark = busy.bench.written().size();
  auto reading = busy.bench.instrument->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->integration_ms, 100);
  EXPECT_EQ(reading->radiance.size(), 401u);
  std::string written = since(busy.bench, mark);
  EXPECT_TRUE(written.starts_with("SE00100\rP\r")) << written.substr(0, 40);
  EXPECT_EQ(count(written, "SE00100\r"), 2u);
  EXPECT_TRUE(in_order(written, "SE00100\rP\r", "SE00100\rT\r")) << written.substr(0, 80);

  // The same exposure: no setup to send, so T is answered busy, then sent again.
  ASSERT_NO_FATAL_FAILURE(busy.leave_measuring());
  mark = busy.bench.written().size();
  reading = busy.bench.instrument->measure({.integration_ms = BusyBench::kExposureMs});
  ASSERT_TRUE(reading) << reading.error().message;
  written = since(busy.bench, mark);
  EXPECT_TRUE(written.starts_with("T\rP\r")) << written.substr(0, 40);
  EXPECT_EQ(count(written, "T\r"), 2u);
}

TEST(MeterSetup, APr7xxPollAnsweringBusyIsPolledAgain) {
  Bench bench(Model::pr730, forced(Model::pr730), meter_options(Model::pr730, {"p:busy=3"}));
  ASSERT_TRUE(bench.instrument->connect());
  auto reading = bench.instrument->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 401u);
  EXPECT_EQ(count(bench.written(), "P\r"), 4u) << "three answered busy, the fourth done";
  EXPECT_EQ(count(bench.written(), "T\r"), 1u);
}

}  // namespace
}  // namespace skinspec::drivers
