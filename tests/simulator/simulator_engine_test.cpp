// The simulated meter byte by byte: framing, the setup state, the measurement buffer, echo,
// what each fault does to the bytes of a reply, and the meter's photometry.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <thread>

#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/simulator/meter.hpp"
#include "support/simulator_rig.hpp"

namespace skinspec::simulator {
namespace {

namespace pp = drivers::pr650;
using testing::ask;
using testing::fast_meter;
using ::testing::HasSubstr;
using testing::MeterRig;
using testing::observer;
using ::testing::StartsWith;
using testing::white_scene;

Synthesis white() { return Synthesis{observer(), {white_scene()}}; }

MeterOptions with_faults(std::vector<std::string> specs) {
  MeterOptions options = fast_meter();
  options.faults = *FaultPlan::parse(specs);
  return options;
}

int data_lines(std::string_view reply) {
  int n = 0;
  for (std::size_t at = reply.find("\n0"); at != std::string_view::npos; at = reply.find("\n0", at + 1)) ++n;
  return n;
}

// ---- Framing ---------------------------------------------------------------------------------

TEST(SimulatorEngine, AcceptsAnyCaseAndCrLfOrCrLfTerminatorsAndIgnoresEmptyLines) {
  MeterRig rig(white());
  for (const std::string command : {"b3\n", "B3\r", "b3\r\n", "\n\r\nb1\n", "B0\r\n\r\n"})
    EXPECT_EQ(ask(*rig.host(), command), "000\r\n") << command;
}

TEST(SimulatorEngine, CommandsSentTogetherAreAnsweredInOrder) {
  MeterRig rig(white());
  EXPECT_EQ(ask(*rig.host(), "b3\nd110\nd201\n"), "000\r\n60912345\r\n00\r\n");
}

TEST(SimulatorEngine, UnknownCommandsGetNoAnswerAndAreReported) {
  MeterRig rig(white());
  for (const std::string command : {"x1\n", "m7\n", "b9\n", "d999\n", "q\n"})
    EXPECT_EQ(testing::ask_expecting_silence(*rig.host(), command), "");
  const auto problems = rig.meter().problems();
  ASSERT_EQ(problems.size(), 5u);
  EXPECT_THAT(problems[0], HasSubstr("unknown command 'X1'"));
}

// ---- Setup -----------------------------------------------------------------------------------

TEST(SimulatorEngine, SetupNamesTheFirstInvalidField) {
  MeterRig rig(white());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"s01,,,,,0,01,1\n", "00\r\n"},    {"S1,,,,,1000,,1\n", "00\r\n"},    {"s01,,,,,,01,1\n", "00\r\n"},
      {"s01,,,,1,0,01,1\n", "00\r\n"},   {"s01,,,,60,0,01,1\n", "00\r\n"},  {"sxx,,,,,0,01,1\n", "01\r\n"},
      {"s13,,,,,0,01,1\n", "50\r\n"},    {"s01,1,,,,0,01,1\n", "02\r\n"},   {"s01,,13,,,0,01,1\n", "03\r\n"},
      {"s01,,,x,,0,01,1\n", "04\r\n"},   {"s01,,,,300,0,01,1\n", "05\r\n"}, {"s01,,,,,5,01,1\n", "06\r\n"},
      {"s01,,,,,7000,01,1\n", "06\r\n"}, {"s01,,,,,0,00,1\n", "07\r\n"},    {"s01,,,,,0,100,1\n", "07\r\n"},
      {"s01,,,,,0,01,2\n", "08\r\n"},    {"s01,,,,,0,01,1,1\n", "09\r\n"},
  };
  for (const auto& [command, reply] : cases) EXPECT_EQ(ask(*rig.host(), command), reply) << command;
  EXPECT_EQ(ask(*rig.host(), "d201\n"), "09\r\n");
}

TEST(SimulatorEngine, RefusedSetupLeavesTheSetupAlone) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,0,01,1\n"), "00\r\n");  // SI units
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,0,01,2\n"), "08\r\n");
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  auto d1 = pp::parse_colorimetric(1, ask(*rig.host(), "d1\n"));
  ASSERT_TRUE(d1);
  EXPECT_NEAR(d1->values[0], 99, 0.1);  // cd/m2, not fL
}

TEST(SimulatorEngine, EnglishUnitsUntilTheSetupAsksForSi) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  auto d1 = pp::parse_colorimetric(1, ask(*rig.host(), "d1\n"));
  ASSERT_TRUE(d1);
  EXPECT_NEAR(d1->values[0], 99 / kCandelaPerFootlambert, 0.05);
}

// ---- Measurements and reports ------------------------------------------------------------------

TEST(SimulatorEngine, ReportsBeforeAnyMeasurementHoldZeros) {
  MeterRig rig(white());
  auto d5 = pp::parse_spectral(ask(*rig.host(), "d5\n"));
  ASSERT_TRUE(d5);
  EXPECT_EQ(d5->quality, 0);
  EXPECT_EQ(d5->values, std::vector<double>(101, 0.0));
  EXPECT_EQ(ask(*rig.host(), "d1\n"), "00,0,0.000E+00,.0000,.0000\r\n");
}

TEST(SimulatorEngine, MeasureAndReportCommandsAgreeWithTheReportsOfTheBuffer) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,0,01,1\n"), "00\r\n");
  for (const int code : {1, 2, 3, 4, 5, 6}) {
    const std::string measured = ask(*rig.host(), fmt::format("m{}\n", code));
    EXPECT_EQ(measured, ask(*rig.host(), fmt::format("d{}\n", code))) << code;
    EXPECT_THAT(measured, StartsWith("00,0")) << code;
  }
  EXPECT_EQ(rig.meter().measurements(), 6u);
}

TEST(SimulatorEngine, ColourReportsOfD65WhiteHaveItsChromaticityAndTemperature) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,0,01,1\n"), "00\r\n");
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  auto d1 = pp::parse_colorimetric(1, ask(*rig.host(), "d1\n"));
  auto d3 = pp::parse_colorimetric(3, ask(*rig.host(), "d3\n"));
  auto d4 = pp::parse_colorimetric(4, ask(*rig.host(), "d4\n"));
  auto d6 = pp::parse_colorimetric(6, ask(*rig.host(), "d6\n"));
  ASSERT_TRUE(d1 && d3 && d4 && d6);
  EXPECT_NEAR(d1->values[1], 0.3127, 0.0015);
  EXPECT_NEAR(d1->values[2], 0.3290, 0.0015);
  EXPECT_NEAR(d3->values[1], 0.1978, 0.0015);
  EXPECT_NEAR(d3->values[2], 0.4683, 0.0015);
  EXPECT_NEAR(d4->values[1], 6504, 60);
  EXPECT_NEAR(d4->values[2], 0.0032, 0.002);
  EXPECT_EQ(d6->values.size(), 5u);
}

TEST(SimulatorEngine, FlickerReportsTheSceneFrequency) {
  MeterRig rig(white());
  auto f = pp::parse_flicker(ask(*rig.host(), "f\n"));
  ASSERT_TRUE(f);
  EXPECT_EQ(f->quality, 0);
  EXPECT_NEAR(f->frequency_hz, 60.02, 1e-9);
}

TEST(SimulatorEngine, SyncToAFrequencyNeverMeasuredFails) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "s01,,,,1,0,01,1\n"), "00\r\n");
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  EXPECT_THAT(ask(*rig.host(), "d1\n"), StartsWith("07,"));
  ASSERT_THAT(ask(*rig.host(), "f\n"), StartsWith("00,"));
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  EXPECT_THAT(ask(*rig.host(), "d1\n"), StartsWith("00,"));
}

TEST(SimulatorEngine, MeasurementTakesItsIntegrationTimesTheTimeScale) {
  MeterOptions options = fast_meter();
  options.time_scale = 0.01;
  MeterRig rig(white(), options);
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,2000,02,1\n", std::chrono::milliseconds(100)), "00\r\n");
  // Two averages of a dark and a light 2 s integration, plus overhead: 8.3 s, so 83 ms here.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(ask(*rig.host(), "m0\n", std::chrono::milliseconds(200)), "000\r\n");
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_GE(took, std::chrono::milliseconds(83));
}

TEST(SimulatorEngine, RepliesArePacedAtTheLineRateTimesTheTimeScale) {
  MeterOptions options = fast_meter();
  options.time_scale = 0.05;  // 1733 bytes at 0.052 ms: about 90 ms
  MeterRig rig(white(), options);
  const auto start = std::chrono::steady_clock::now();
  const std::string d5 = ask(*rig.host(), "d5\n", std::chrono::milliseconds(200));
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(d5.size(), 1733u);
  EXPECT_GE(took, std::chrono::milliseconds(85));
}

// ---- Echo -----------------------------------------------------------------------------------

TEST(SimulatorEngine, EchoModeEchoesEachCharacterAndPromptsWhenReady) {
  MeterRig rig(white());
  EXPECT_EQ(ask(*rig.host(), "b3\n"), "000\r\n");
  EXPECT_EQ(ask(*rig.host(), "E\n"), ">");
  EXPECT_EQ(ask(*rig.host(), "b3\n"), "b3\n000\r\n>");
  EXPECT_EQ(ask(*rig.host(), "D110\r"), "D110\r60912345\r\n>");
  EXPECT_EQ(ask(*rig.host(), "x\n"), "x\n>");
  rig.meter().power_cycle();
  EXPECT_EQ(ask(*rig.host(), "b3\n"), "000\r\n");
}

// ---- Faults on bytes --------------------------------------------------------------------------

TEST(SimulatorEngine, TruncateKeepsTheGivenBytesOrHalf) {
  MeterRig rig(white(), with_faults({"d5:truncate=100@1", "d5:truncate@2"}));
  EXPECT_EQ(ask(*rig.host(), "d5\n").size(), 100u);
  EXPECT_EQ(ask(*rig.host(), "d5\n").size(), 1733u / 2);
  EXPECT_EQ(ask(*rig.host(), "d5\n").size(), 1733u);
}

TEST(SimulatorEngine, LineCountCutsOrExtendsTheDataLines) {
  MeterRig rig(white(), with_faults({"d5:line-count=99@1", "d5:line-count=103@2"}));
  EXPECT_EQ(data_lines(ask(*rig.host(), "d5\n")), 99);
  const std::string longer = ask(*rig.host(), "d5\n");
  EXPECT_EQ(data_lines(longer), 103);
  EXPECT_THAT(longer, HasSubstr("\r\n0788.,"));
}

TEST(SimulatorEngine, DropLineLeavesOutOneLine) {
  MeterRig rig(white(), with_faults({"d5:drop-line=2@1", "d5:drop-line@2"}));
  const std::string second_line_gone = ask(*rig.host(), "d5\n");
  EXPECT_EQ(second_line_gone.find("0380.,"), std::string::npos);
  EXPECT_EQ(data_lines(second_line_gone), 100);
  EXPECT_EQ(data_lines(ask(*rig.host(), "d5\n")), 100);
  EXPECT_EQ(data_lines(ask(*rig.host(), "d5\n")), 101);
}

TEST(SimulatorEngine, GarbageInsertsBytesInsideTheReply) {
  MeterRig rig(white(), with_faults({"b3:garbage=5"}));
  const std::string reply = ask(*rig.host(), "b3\n");
  EXPECT_EQ(reply.size(), 10u);
  EXPECT_THAT(reply, ::testing::EndsWith("\r\n"));
  EXPECT_NE(reply, "000\r\n");
}

TEST(SimulatorEngine, BitflipChangesExactlyOneBit) {
  MeterRig rig(white(), with_faults({"d5:bitflip"}));
  const std::string damaged = ask(*rig.host(), "d5\n");
  MeterRig plain(white());
  const std::string reference = ask(*plain.host(), "d5\n");
  ASSERT_EQ(damaged.size(), reference.size());
  int bits = 0;
  for (std::size_t i = 0; i < reference.size(); ++i)
    bits += std::popcount(static_cast<unsigned>(static_cast<unsigned char>(damaged[i] ^ reference[i])));
  EXPECT_EQ(bits, 1);
}

TEST(SimulatorEngine, ExponentHeaderAndQualityFaultsRewriteTheReport) {
  MeterRig rig(white(), with_faults({"d5:exponent=e", "d5:header=h2", "d1:quality=19"}));
  const std::string d5 = ask(*rig.host(), "d5\n");
  EXPECT_THAT(d5, StartsWith("00,0\r\n0.000e+00\r\n0380.,0.000e+00\r\n"));
  EXPECT_EQ(d5.size(), 1734u);
  EXPECT_THAT(ask(*rig.host(), "d1\n"), StartsWith("19,0,"));
}

TEST(SimulatorEngine, NoAnswerSwallowsTheCommandWithoutEffect) {
  MeterRig rig(white(), with_faults({"s:no-answer@1"}));
  EXPECT_EQ(testing::ask_expecting_silence(*rig.host(), "s01,,,,,0,01,2\n"), "");
  EXPECT_EQ(ask(*rig.host(), "d201\n"), "00\r\n");
}

TEST(SimulatorEngine, LateAddsRealTimeEvenAtTimeScaleZero) {
  MeterRig rig(white(), with_faults({"b3:late=80"}));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(ask(*rig.host(), "b3\n", std::chrono::milliseconds(150)), "000\r\n");
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(80));
}

TEST(SimulatorEngine, DisconnectSendsPartOfTheReplyThenClosesTheLink) {
  MeterRig rig(white(), with_faults({"d5:disconnect=300"}));
  EXPECT_EQ(ask(*rig.host(), "d5\n").size(), 300u);
  EXPECT_EQ(rig.wait_for_end(), SimulatedMeter::ServeEnd::disconnected);
  char byte;
  auto n = rig.host()->read(&byte, 1, drivers::deadline_in(std::chrono::milliseconds(50)));
  ASSERT_FALSE(n);
  EXPECT_EQ(n.error().kind, drivers::TransportError::Kind::closed);
}

TEST(SimulatorEngine, FaultsAreLogged) {
  MeterRig rig(white(), with_faults({"b3:truncate=1"}));
  ask(*rig.host(), "b3\n");
  EXPECT_THAT(rig.log(), ::testing::Contains(HasSubstr("fault truncate=1 on 'B3'")));
}

// ---- Power-on window --------------------------------------------------------------------------

TEST(SimulatorEngine, WindowMissedMeansSilenceEvenForValidCommands) {
  MeterOptions options = fast_meter();
  options.boot_window_s = 0.02;
  MeterRig rig(white(), options);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(testing::ask_expecting_silence(*rig.host(), "b3\n"), "");
  EXPECT_EQ(testing::ask_expecting_silence(*rig.host(), "d110\n"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
  rig.meter().power_cycle();
  EXPECT_EQ(ask(*rig.host(), "d110\n"), "60912345\r\n");
}

TEST(SimulatorEngine, PowerCycleClearsSetupAndBufferButKeepsTheScene) {
  MeterRig rig(white());
  ASSERT_EQ(ask(*rig.host(), "s01,,,,,0,01,1\n"), "00\r\n");
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  rig.meter().power_cycle();
  EXPECT_EQ(ask(*rig.host(), "d1\n"), "00,0,0.000E+00,.0000,.0000\r\n");
  ASSERT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  auto d1 = pp::parse_colorimetric(1, ask(*rig.host(), "d1\n"));
  ASSERT_TRUE(d1);
  EXPECT_NEAR(d1->values[0], 99 / kCandelaPerFootlambert, 0.05);  // English units again
}

// ---- Scenes and photometry --------------------------------------------------------------------

TEST(SimulatorScenes, WhiteUnderALampHasTheLampsLuminanceAndWhitePoint) {
  const auto& colour = testing::colour_data();
  const Lamp a{"A", colour.a, 250};
  const Scene white = scene_under_lamp("white", *Spectrum::create({380, 780}, {1.0, 1.0}), a, observer());
  const Photometry p = photometry(white.radiance, observer());
  EXPECT_NEAR(p.Y, 250, 1e-9);
  EXPECT_NEAR(p.x, 0.4476, 0.001);
  EXPECT_NEAR(p.y, 0.4074, 0.001);
  EXPECT_NEAR(p.cct, 2856, 30);
  EXPECT_NEAR(p.duv, 0, 0.002);
}

TEST(SimulatorScenes, BlackHasNoColour) {
  const Photometry p = photometry(std::vector<double>(101, 0.0), observer());
  EXPECT_EQ(p.Y, 0);
  EXPECT_EQ(p.x, 0);
  EXPECT_EQ(p.cct, 0);
}

TEST(SimulatorScenes, RadianceCsvGivesOneScenePerColumnOnTheNativeGrid) {
  const std::string csv = "wavelength_nm,lamp,led\n380,0.001,0\n700,0.002,0.5\n780,0.003,0.25\n";
  auto scenes = radiance_scenes(csv, "radiance.csv");
  ASSERT_TRUE(scenes) << scenes.error();
  ASSERT_EQ(scenes->size(), 2u);
  EXPECT_EQ((*scenes)[0].name, "lamp");
  EXPECT_EQ((*scenes)[1].radiance.size(), 101u);
  EXPECT_NEAR((*scenes)[0].radiance[80], 0.002, 1e-12);  // 700 nm
  EXPECT_NEAR((*scenes)[1].radiance[90], 0.375, 1e-12);  // 740 nm
}

TEST(SimulatorScenes, BadSpectraFilesAreRefusedWithTheirLocation) {
  auto scenes = radiance_scenes("wavelength_nm,a\n380,x\n780,1\n", "bad.csv");
  ASSERT_FALSE(scenes);
  EXPECT_THAT(scenes.error(), HasSubstr("bad.csv:2"));
  const Lamp d65{"D65", testing::colour_data().d65, 100};
  auto reflectance = reflectance_scenes("wavelength_nm,a\n380,2\n780,1\n", "r.csv", d65, observer());
  ASSERT_FALSE(reflectance);
  EXPECT_THAT(reflectance.error(), HasSubstr("r.csv"));
}

}  // namespace
}  // namespace skinspec::simulator
