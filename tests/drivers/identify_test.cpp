// Which meter answers on a link: `--model auto` against every simulated model in process, the
// answers that tell the families apart, forced models the meter contradicts, models skinspec
// does not know, and a probe that finds nothing or is cancelled.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <thread>

#include "skinspec/drivers/identification.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "support/meter_bench.hpp"
#include "support/scripted_meter.hpp"

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;
using simulator::MeterOptions;
using ::testing::HasSubstr;
using testing::meter_options;
using K = InstrumentError::Kind;
using Bench = testing::InstrumentBench;
using testing::fast_options;

std::size_t count(std::string_view text, std::string_view what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string_view::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

ModelChoice forced(Model model) { return ModelChoice{model}; }

void enter_remote_mode(Transport& link) { EXPECT_EQ(testing::ask(link, "PHOTO"), pr6xx::kBanner); }

void pr650_echo_on(Transport& link) {
  EXPECT_THAT(testing::ask(link, "b3\n"), HasSubstr("000"));
  (void)testing::ask(link, "E\n");
}

// ---- The answers that tell the families apart -------------------------------------------------

TEST(Identification, TheAnswerToB3NamesTheFamily) {
  using identification::classify_contact;
  using identification::ContactAnswer;
  for (const std::string_view pr650 : {"000\r\n", "00\r\n", "0\r\n"})
    EXPECT_EQ(classify_contact(pr650), ContactAnswer::pr650) << pr650;
  for (const std::string_view newer :
       {"Backlight set to 3 %\r\n", "0000\r\n", "00000\r\n", "-1000\r\n", "-0008\r\n", "0001\r\n", "00000,PR-670\r\n"})
    EXPECT_EQ(classify_contact(newer), ContactAnswer::newer_meter) << newer;
  for (const std::string_view other : {"D\r\n", "012\r\n", "hello\r\n", "00a\r\n"})
    EXPECT_EQ(classify_contact(other), ContactAnswer::other) << other;
}

TEST(Identification, TheAnswerToPhotoNamesTheFamily) {
  using identification::classify_photo;
  using identification::PhotoAnswer;
  EXPECT_EQ(classify_photo(""), PhotoAnswer::silence);
  EXPECT_EQ(classify_photo("\r\n"), PhotoAnswer::silence);
  for (const std::string_view banner :
       {" REMOTE MODE", " REMOTE MODE\r\n", "REMOTE MODE", " REMOTE MODE00000,PR-730/735\r\n"})
    EXPECT_EQ(classify_photo(banner), PhotoAnswer::banner) << banner;
  for (const std::string_view glued : {"00000,PR-730/735\r\n", "0000\r\n", "-1000\r\n"})
    EXPECT_EQ(classify_photo(glued), PhotoAnswer::newer_meter) << glued;
  for (const std::string_view pr650 : {"PHOTO", "QPHOTO", "PHOTO>", ">", "000\r\n"})
    EXPECT_EQ(classify_photo(pr650), PhotoAnswer::pr650) << pr650;
  for (const std::string_view other : {"D\r\n", " REM", "OK\r\n"})
    EXPECT_EQ(classify_photo(other), PhotoAnswer::other) << other;
}

// ---- --model auto ------------------------------------------------------------------------------

TEST(Identification, AutoFindsEveryModelAndMeasuresOnItsGrid) {
  for (const MeterProfile& row : all_profiles()) {
    Bench bench(row.model);
    auto connected = bench.instrument->connect();
    ASSERT_TRUE(connected) << row.id << ": " << connected.error().message;
    auto identity = bench.instrument->identify();
    ASSERT_TRUE(identity) << row.id << ": " << identity.error().message;
    EXPECT_EQ(identity->model, row.model) << row.id;
    EXPECT_EQ(identity->family, row.family) << row.id;
    EXPECT_EQ(identity->serial_number, row.serial) << row.id;
    EXPECT_EQ(bench.instrument->serial_number(), row.serial) << row.id;
    EXPECT_EQ(identity->firmware, row.family == Family::pr650 ? "" : "2.22D") << row.id;
    EXPECT_EQ(identity->reported_model, row.family == Family::pr650 ? "PR-650" : row.d111) << row.id;
    EXPECT_EQ(identity->grid, *row.simulator_grid) << row.id;
    EXPECT_TRUE(identity->warnings.empty()) << row.id << ": " << identity->warnings.front();

    auto reading = bench.instrument->measure({.integration_ms = 100});
    ASSERT_TRUE(reading) << row.id << ": " << reading.error().message;
    EXPECT_EQ(reading->radiance.size(), static_cast<std::size_t>(row.simulator_grid->points)) << row.id;
    EXPECT_NEAR(reading->radiance[50], bench.scene.radiance[50], 1e-3 * bench.scene.radiance[50]) << row.id;

    const std::string written = bench.written();
    EXPECT_TRUE(written.starts_with("b3\n")) << row.id << ": the PR-650 is asked first";
    if (row.family == Family::pr650) {
      EXPECT_EQ(written.find("PHOTO"), std::string::npos) << row.id;
    } else {
      EXPECT_TRUE(written.starts_with("b3\nQPHOTOD111\r")) << row.id << ": " << written.substr(0, 20);
      EXPECT_EQ(count(written, "PHOTO"), 1u) << row.id << ": the driver takes the meter over in remote mode";
    }
  }
}

TEST(Identification, AutoFindsTheProfileTheD120GridPointsTo) {
  // The PR-730 and PR-735 both report "PR-730/735"; the manuals' 2 nm D120 example is a PR-730's.
  MeterOptions manual = meter_options(Model::pr735);
  manual.wire.d120_manual = true;
  Bench bench(Model::pr735, {}, std::move(manual));
  ASSERT_TRUE(bench.instrument->connect());
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->model, Model::pr730);
  EXPECT_EQ(identity->reported_model, "PR-730/735");
  EXPECT_EQ(identity->grid, (Grid{380, 780, 2, 201}));
}

TEST(Identification, AutoResetsANewerMeterLeftInRemoteMode) {
  Bench bench(Model::pr670, {}, meter_options(Model::pr670), enter_remote_mode);
  auto connected = bench.instrument->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  EXPECT_EQ(bench.logged("command Q: remote mode left"), 1u);
  EXPECT_EQ(bench.logged("command PHOTO: remote mode"), 2u) << "once by the other program, once by the probe";
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity);
  EXPECT_EQ(identity->model, Model::pr670);
}

TEST(Identification, AutoTakesABannerGluedToTheNextReply) {
  Bench bench(Model::pr730, {}, meter_options(Model::pr730, {"photo:glue"}));
  auto connected = bench.instrument->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->model, Model::pr730);
  EXPECT_THAT(identity->warnings, ::testing::ElementsAre(HasSubstr("banner-glued")));
  auto reading = bench.instrument->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 401u);
}

TEST(Identification, AutoFindsAPr650ThatAnswersOnlyAfterTheNewerMetersWereAskedFor) {
  Bench bench(Model::pr650, {}, meter_options(Model::pr650, {"b3:no-answer@1"}));
  auto connected = bench.instrument->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  const std::string written = bench.written();
  EXPECT_EQ(count(written, "PHOTO"), 2u) << written;
  // A lone line end first ends what the newer meters' commands left in the PR-650's line buffer.
  EXPECT_TRUE(written.ends_with("D111\r\nb3\n")) << written;
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity);
  EXPECT_EQ(identity->model, Model::pr650);
}

TEST(Identification, AutoFindsAPr650InEchoMode) {
  Bench bench(Model::pr650, {}, meter_options(Model::pr650), pr650_echo_on);
  auto connected = bench.instrument->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->family, Family::pr650);
}

TEST(Identification, AutoConnectsAgainAndLeavesRemoteModeWhenDone) {
  Bench bench(Model::pr730);
  ASSERT_TRUE(bench.instrument->connect());
  ASSERT_TRUE(bench.instrument->measure({.integration_ms = 100}));
  const auto replies = bench.instrument->replies_received();
  EXPECT_GT(replies, 0u);
  auto again = bench.instrument->connect();
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_TRUE(bench.instrument->connected());
  EXPECT_GT(bench.instrument->replies_received(), replies);
  ASSERT_TRUE(bench.instrument->measure({.integration_ms = 100}));
  bench.instrument.reset();
  EXPECT_TRUE(bench.written().ends_with("Q"));
  bench.rig.wait_for_end(200ms);
  EXPECT_EQ(bench.logged("command Q: remote mode left"), 2u) << "the first connection's, then the last";
}

TEST(Identification, AutoRefusesAModelSkinspecDoesNotKnow) {
  MeterOptions unknown = meter_options(Model::pr670);
  unknown.wire.d111 = "PR-810";
  Bench bench(Model::pr670, {}, std::move(unknown));
  auto refused = bench.instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message, HasSubstr("the meter reports 'PR-810', which skinspec does not know"));
  EXPECT_THAT(refused.error().message, HasSubstr("give --model with the closest model (pr655, pr670"));
  EXPECT_FALSE(bench.instrument->connected());
  EXPECT_TRUE(bench.written().ends_with("D111\rQ")) << "remote mode left";
}

TEST(Identification, NothingAnsweringIsNoContactForBothFamilies) {
  auto [host, device] = make_memory_pair("silent");
  auto tap = std::make_unique<testing::WireTap>(std::move(host));
  const auto written = tap->written();
  auto instrument = make_instrument(std::move(tap), {}, fast_options());
  auto refused = instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::no_contact);
  EXPECT_THAT(refused.error().message, HasSubstr("neither a PR-650 (to 'b3', 3 times)"));
  EXPECT_THAT(refused.error().message, HasSubstr("within about 5 s of being switched on"));
  EXPECT_THAT(refused.error().message, HasSubstr("Power Saving off"));
  EXPECT_EQ(count(written(), "b3\n"), 3u) << "the first attempt, then the remaining two";
  EXPECT_EQ(count(written(), "PHOTO"), 2u);
}

TEST(Identification, AnotherDeviceIsNotTakenForAMeter) {
  auto [host, device] = make_memory_pair("modem");
  testing::ScriptedMeter modem(std::move(device), {{"b3", "D\r\n"}});
  auto instrument = make_instrument(std::move(host), {}, fast_options());
  auto refused = instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message, HasSubstr("answered 'b3' with \"D\\r\\n\""));
  EXPECT_THAT(refused.error().message, HasSubstr("not a Photo Research meter?"));
  EXPECT_EQ(modem.mismatch(), "");
}

TEST(Identification, CancelEndsTheProbeAtEveryStep) {
  // With the real timings a silent link takes the probe well over 10 s.
  InstrumentOptions slow;
  slow.pr650.modem_settle = 0ms;
  slow.remote.pacing = 0ms;
  for (const auto& [contact, cancel_after] : {std::pair{2000ms, 50ms}, std::pair{100ms, 500ms}}) {
    slow.pr650.timing.contact = contact;
    auto [host, device] = make_memory_pair("silent");
    auto instrument = make_instrument(std::move(host), {}, slow);
    std::thread canceller([&, wait = cancel_after] {
      std::this_thread::sleep_for(wait);
      instrument->cancel();
    });
    const auto start = std::chrono::steady_clock::now();
    auto cancelled = instrument->connect();
    canceller.join();
    ASSERT_FALSE(cancelled);
    EXPECT_EQ(cancelled.error().kind, K::cancelled) << cancelled.error().message;
    EXPECT_LT(std::chrono::steady_clock::now() - start, 5s) << "cancelled after " << cancel_after.count() << " ms";
  }
}

// ---- Forced models -----------------------------------------------------------------------------

TEST(Identification, AForcedModelTheMeterContradictsIsRefused) {
  Bench bench(Model::pr740, forced(Model::pr670));
  auto refused = bench.instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message,
              HasSubstr("--model pr670 asks for a PR-670, but the meter says it is a 'PR-740'"));

  Bench listed(Model::pr735, forced(Model::pr730));
  EXPECT_TRUE(listed.instrument->connect()) << "'PR-730/735' names the PR-730 too";
}

TEST(Identification, AForcedModelMeasuresAModelSkinspecDoesNotKnowWithAWarning) {
  MeterOptions unknown = meter_options(Model::pr670);
  unknown.wire.d111 = "PR-810";
  Bench bench(Model::pr670, forced(Model::pr670), std::move(unknown));
  auto connected = bench.instrument->connect();
  ASSERT_TRUE(connected) << connected.error().message;
  auto identity = bench.instrument->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->model, std::nullopt);
  EXPECT_EQ(identity->family, Family::pr6xx);
  EXPECT_EQ(identity->reported_model, "PR-810");
  EXPECT_THAT(identity->warnings,
              ::testing::ElementsAre(HasSubstr("unknown-model: the meter reports 'PR-810', which skinspec does not "
                                               "know; measured as a PR-670 because --model says so")));
  auto reading = bench.instrument->measure({.integration_ms = 100});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.size(), 201u);
}

TEST(Identification, AForcedPr650RefusesANewerMeter) {
  Bench bench(Model::pr670, forced(Model::pr650), meter_options(Model::pr670), enter_remote_mode);
  auto refused = bench.instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message, HasSubstr("a PR-6xx/7xx answered"));
  EXPECT_THAT(refused.error().message, HasSubstr("\"Backlight set to 3 %\\r\\n\" to 'b3'"));
  EXPECT_THAT(refused.error().message, HasSubstr("use --model auto"));
}

TEST(Identification, APr650AnsweringPhotoIsTheWrongFamily) {
  Bench bench(Model::pr650, forced(Model::pr670), meter_options(Model::pr650), pr650_echo_on);
  auto refused = bench.instrument->connect();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, K::identification);
  EXPECT_THAT(refused.error().message, HasSubstr("a PR-650 answered PHOTO"));
  EXPECT_THAT(refused.error().message, HasSubstr("use --model pr650 or auto"));
}

}  // namespace
}  // namespace skinspec::drivers
