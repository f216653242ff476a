// The simulated PR-655/670/680 and PR-7xx byte by byte: local and remote mode, every example
// exchange of the manuals (docs/pr6xx-protocol.md) at time scale 0, the sequences PsychoPy and
// Psychtoolbox send, the faults of the newer meters, and recordings of version 2.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <sstream>
#include <thread>

#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "skinspec/drivers/pr7xx_protocol.hpp"
#include "skinspec/simulator/meter.hpp"
#include "support/simulator_rig.hpp"

namespace skinspec::simulator {
namespace {

namespace p6 = drivers::pr6xx;
using drivers::Model;
using testing::ask;
using testing::ask_expecting_silence;
using ::testing::HasSubstr;
using testing::MeterRig;

const std::string kRecordings = SKINSPEC_TEST_RECORDINGS_DIR;

// A white standard under D65 seen by `model`, on its grid; `flicker_hz` 0 is a steady lamp.
Synthesis white_for(Model model, double white_luminance = 100, double flicker_hz = 60) {
  const auto grid = wavelengths(*drivers::profile(model).simulator_grid);
  auto colour = ColourData::load(directory_reader(SKINSPEC_TEST_DATA_DIR), grid);
  const Lamp lamp{"D65", colour->d65, white_luminance};
  Scene scene = scene_under_lamp("white standard", *Spectrum::create({380, 780}, {0.99, 0.99}), lamp, colour->observer);
  scene.flicker_hz = flicker_hz;
  return Synthesis{colour->observer, {scene}};
}

MeterOptions options_for(Model model, std::vector<std::string> faults = {}) {
  MeterOptions options = testing::fast_meter();
  options.model = model;
  options.faults = *FaultPlan::parse(faults);
  return options;
}

// A meter of `model` already in remote mode.
struct Remote {
  explicit Remote(Model model, std::vector<std::string> faults = {})
      : rig(white_for(model), options_for(model, std::move(faults))) {
    EXPECT_EQ(ask(link(), "PHOTO"), p6::kBanner);
  }
  drivers::Transport& link() { return *rig.host(); }
  MeterRig rig;
};

std::vector<std::string> lines_of(std::string_view reply) {
  std::vector<std::string> lines;
  std::istringstream in{std::string(reply)};
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Writes one byte at a time, as Psychtoolbox and the PsychoPy plugin do.
void send_paced(drivers::Transport& link, std::string_view bytes) {
  for (const char c : bytes) {
    (void)link.write(std::string_view(&c, 1), drivers::deadline_in(std::chrono::seconds(1)));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

// ---- Local and remote mode -------------------------------------------------------------------

TEST(SimulatorPr6xx, SilentOutsideRemoteModeAndPhotoAnswersOnlyOnce) {
  MeterRig rig(white_for(Model::pr670), options_for(Model::pr670));
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "Q"), "");
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "D111\r"), "");
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "photo"), "") << "PHOTO is case-sensitive";
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), " REMOTE MODE");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::remote);
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "PHOTO"), "");
  EXPECT_EQ(ask(*rig.host(), "d111\n"), "00000,PR-670\r\n") << "lower case and LF";
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "Q"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "D111\r"), "");
  EXPECT_EQ(ask(*rig.host(), "junkPHOTO"), " REMOTE MODE") << "PHOTO found after other bytes";
  const auto log = rig.log();
  EXPECT_TRUE(std::ranges::any_of(log, [](const std::string& l) { return l == "command Q: remote mode left"; }));
  EXPECT_TRUE(
      std::ranges::any_of(log, [](const std::string& l) { return l.ends_with("ignored outside remote mode"); }));
}

TEST(SimulatorPr6xx, EveryNewerModelHasItsIdentityAndGrid) {
  for (const auto& row : drivers::all_profiles()) {
    if (!row.caps.remote_keyword) continue;
    Remote meter(row.model);
    EXPECT_EQ(ask(meter.link(), "D111\r"), fmt::format("00000,{}\r\n", row.d111)) << row.id;
    EXPECT_EQ(ask(meter.link(), "D110\r"), fmt::format("00000,{}\r\n", row.serial)) << row.id;
    auto configuration = p6::parse_hardware_configuration(ask(meter.link(), "D120\r"));
    ASSERT_TRUE(configuration) << row.id;
    EXPECT_EQ(configuration->grid, *row.simulator_grid) << row.id;
    const std::string spectrum = ask(meter.link(), "M5\r");
    auto report = p6::parse_spectral(spectrum, *row.simulator_grid);
    ASSERT_TRUE(report) << row.id << ": " << report.error().message;
    EXPECT_EQ(report->status.code, 0) << row.id;
    EXPECT_EQ(report->exponent_digits, row.wire.data_exponent_digits) << row.id;
    EXPECT_NEAR(report->integrated,
                std::accumulate(report->values.begin(), report->values.end(), 0.0) * row.simulator_grid->step_nm,
                1e-3 * report->integrated)
        << row.id;
  }
}

// ---- The manuals' examples (docs/pr6xx-protocol.md, "Example exchanges") ---------------------

TEST(SimulatorPr6xx, Pr670AnswersTheManualsExamples) {
  Remote meter(Model::pr670);
  const std::vector<std::pair<std::string, std::string>> rows = {
      {"D111\r", "00000,PR-670\r\n"},
      {"D110\r", "00000,67065106\r\n"},
      {"D114\r", "00000,2.22D\r\n"},
      {"D120\r", "00000,201,0.00,380,780,2,256,7,247\r\n"},
      {"D117\r", "00000,0,1 deg,0.00\r\n00000,1,1/2 deg,0.00\r\n00000,2,1/4 deg,0.00\r\n00000,3,1/8 deg,0.00\r\n"},
      {"D5\r", "-2000\r\n"},
      {"F\r", "0000,60.00 Hertz (Period = 16.67 milliseconds)\r\n"},
      {"SS1\r", "0000\r\n"},
      {"SE0\r", "0000\r\n"},
      {"SN01\r", "0000\r\n"},
      {"SE99999\r", "-1010\r\n"},
      {"SK500\r", "-1019\r\n"},
      {"I\r", "0000\r\n"},
      {"X\r", "-1000\r\n"},
  };
  for (const auto& [tx, rx] : rows) EXPECT_EQ(ask(meter.link(), tx), rx) << tx;
}

TEST(SimulatorPr6xx, Pr670MeasuresOnItsTwoNanometreGrid) {
  Remote meter(Model::pr670);
  const std::string reply = ask(meter.link(), "M5\r");
  const auto lines = lines_of(reply);
  ASSERT_EQ(lines.size(), 202u);
  EXPECT_THAT(lines[0], ::testing::MatchesRegex("00000,0,[0-9]\\.[0-9]{3}e\\+[0-9]{3},.*\r"));
  EXPECT_THAT(lines[1], ::testing::StartsWith("380,"));
  EXPECT_THAT(lines[2], ::testing::StartsWith("382,"));
  EXPECT_THAT(lines[201], ::testing::StartsWith("780,"));
  EXPECT_TRUE(reply.ends_with("\r\n"));
  auto xy = p6::parse_colorimetric(1, ask(meter.link(), "D1\r"));
  ASSERT_TRUE(xy);
  EXPECT_NEAR(xy->values[1], 0.3127, 0.002);  // a white under D65
  EXPECT_NEAR(xy->values[2], 0.3290, 0.002);
  EXPECT_NEAR(xy->values[0] * kCandelaPerFootlambert, 99, 1.0);  // fL at power-on
  EXPECT_EQ(ask(meter.link(), "SU1\r"), "0000\r\n");
  EXPECT_EQ(ask(meter.link(), "M1\r").substr(0, 8), "00000,1,");
}

TEST(SimulatorPr6xx, TooDarkAnswersWithTheCodeAlone) {
  MeterRig rig(white_for(Model::pr670, 1e-6), options_for(Model::pr670));
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), " REMOTE MODE");
  EXPECT_EQ(ask(*rig.host(), "M5\r"), "-8\r\n");
  EXPECT_EQ(ask(*rig.host(), "D5\r"), "-8\r\n") << "no stale spectrum after a failed measurement";
  EXPECT_EQ(ask(*rig.host(), "D1\r"), "-8\r\n");
}

TEST(SimulatorPr6xx, SyncOnASteadyLampFails) {
  MeterRig rig(white_for(Model::pr670, 100, 0), options_for(Model::pr670));
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), " REMOTE MODE");
  EXPECT_EQ(ask(*rig.host(), "F\r"), "-3\r\n");
  EXPECT_EQ(ask(*rig.host(), "SS1\r"), "0000\r\n");
  EXPECT_EQ(ask(*rig.host(), "M5\r"), "-10\r\n");
  EXPECT_EQ(ask(*rig.host(), "SS3\r"), "0000\r\n");
  EXPECT_EQ(ask(*rig.host(), "M5\r"), "-3\r\n");
}

TEST(SimulatorPr6xx, Pr655ServesPsychopyStyleLinesAndItsOwnWireStyle) {
  MeterRig rig(white_for(Model::pr655), options_for(Model::pr655));
  EXPECT_EQ(ask(*rig.host(), "PHOTO\n"), " REMOTE MODE");
  EXPECT_EQ(ask(*rig.host(), "D111\n"), "00000,PR-655\r\n");
  EXPECT_EQ(ask(*rig.host(), "D120\r"), "00000,101,0.00,380,780,4,256,7,247\r\n");
  EXPECT_EQ(ask(*rig.host(), "SH1\r"), "-1035\r\n");
  EXPECT_EQ(ask(*rig.host(), "SF1\r"), "-1035\r\n");
  EXPECT_EQ(ask(*rig.host(), "D117\r"), "-1035\r\n");
  EXPECT_EQ(ask(*rig.host(), "SE2\r"), "-1010\r\n");
  EXPECT_EQ(ask(*rig.host(), "SE3\r"), "0000\r\n");
  EXPECT_EQ(ask(*rig.host(), "B3\r"), "Backlight set to 3 %\r\n");
  EXPECT_EQ(ask(*rig.host(), "SE0\r"), "0000\r\n");
  const std::string reply = ask(*rig.host(), "M5\r");
  const auto at = reply.find("380,");
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(reply.size() - at, 101u * 16) << "Psychtoolbox's PR-655 parser reads at a 16-byte stride";
  EXPECT_EQ(reply.substr(at + 16, 4), "384,");
}

TEST(SimulatorPr6xx, Pr7xxTriggersPollsAndAborts) {
  MeterOptions options = options_for(Model::pr730);
  options.time_scale = 1;
  MeterRig rig(white_for(Model::pr730), options);
  drivers::Transport& link = *rig.host();
  EXPECT_EQ(ask(link, "PHOTO"), " REMOTE MODE");
  EXPECT_EQ(ask(link, "D120\r"), "00000,401,0.00,380,780,1,256,7,247\r\n");
  EXPECT_EQ(ask(link, "A\r"), "0001\r\n") << "nothing to abort";
  EXPECT_EQ(ask(link, "SE100000\r"), "0000\r\n");
  EXPECT_EQ(ask(link, "T\r"), "0000\r\n");
  EXPECT_EQ(ask(link, "P\r"), "0001\r\n");
  EXPECT_EQ(ask(link, "SE100\r"), "0001\r\n") << "setup refused while busy";
  EXPECT_EQ(ask(link, "A\r"), "0000\r\n");
  EXPECT_EQ(ask(link, "P\r"), "0000,0\r\n");
  EXPECT_EQ(ask(link, "V\r"), "00000\r\n");
  EXPECT_EQ(ask(link, "D5\r"), "-2000\r\n") << "the aborted measurement left nothing";
}

TEST(SimulatorPr6xx, Pr7xxMeasurementEndsAndItsSpectrumCoversTheGrid) {
  for (const Model model : {Model::pr730, Model::pr735}) {
    const auto& row = drivers::profile(model);
    Remote meter(model, {"p:busy=2"});
    EXPECT_EQ(ask(meter.link(), "T\r"), "0000\r\n");
    EXPECT_EQ(ask(meter.link(), "P\r"), "0001\r\n");
    EXPECT_EQ(ask(meter.link(), "P\r"), "0001\r\n");
    EXPECT_EQ(ask(meter.link(), "P\r"), "0000,0\r\n");
    const auto lines = lines_of(ask(meter.link(), "D5\r"));
    ASSERT_EQ(lines.size(), static_cast<std::size_t>(row.simulator_grid->points) + 1) << row.id;
    EXPECT_EQ(lines.back(),
              fmt::format("{},", row.simulator_grid->last_nm) + lines.back().substr(lines.back().find(',') + 1));
  }
}

TEST(SimulatorPr6xx, Pr740PadsItsErrors) {
  Remote meter(Model::pr740, {"m5:error=-8"});
  EXPECT_EQ(ask(meter.link(), "D111\r"), "00000,PR-740\r\n");
  EXPECT_EQ(ask(meter.link(), "M5\r"), "-0008\r\n");
  EXPECT_EQ(ask(meter.link(), "V\r"), "-0008\r\n");
}

TEST(SimulatorPr6xx, WireOverridesChangeWhatIsPrinted) {
  MeterOptions options = options_for(Model::pr730);
  options.wire.banner = drivers::BannerEnd::crlf;
  options.wire.d111 = "PR-810";
  options.wire.d120_manual = true;
  options.wire.padded_errors = true;
  options.wire.status_digits = 4;
  options.wire.exponent_digits = 3;
  MeterRig rig(white_for(Model::pr730), options);
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), " REMOTE MODE\r\n");
  EXPECT_EQ(ask(*rig.host(), "D111\r"), "0000,PR-810\r\n");
  EXPECT_EQ(ask(*rig.host(), "D120\r"), "0000,201,0.00,380,780,2,256,7,247\r\n");
  EXPECT_EQ(ask(*rig.host(), "D5\r"), "-2000\r\n");
  EXPECT_THAT(ask(*rig.host(), "M5\r"), HasSubstr("\r\n381,"));
  EXPECT_THAT(ask(*rig.host(), "SE1\r"), "-1010\r\n");
}

TEST(SimulatorPr6xx, EchoTogglesWithAPromptWhileOn) {
  Remote meter(Model::pr670);
  EXPECT_EQ(ask(meter.link(), "E\r"), ">");
  EXPECT_EQ(ask(meter.link(), "D111\r"), "D111\r00000,PR-670\r\n>");
  EXPECT_EQ(ask(meter.link(), "E\r"), "E\r") << "the echo of E, then no prompt";
  EXPECT_EQ(ask(meter.link(), "D111\r"), "00000,PR-670\r\n");
}

// ---- Field clients ---------------------------------------------------------------------------

// PsychoPy's PR655 class: whole strings ended by LF, readline per reply, readlines for D5.
TEST(SimulatorPr6xx, ServesPsychopysPr655Sequence) {
  MeterRig rig(white_for(Model::pr655), options_for(Model::pr655));
  drivers::Transport& link = *rig.host();
  EXPECT_EQ(ask(link, "PHOTO\n"), " REMOTE MODE");
  const std::string type = ask(link, "D111\n");
  EXPECT_EQ(type.substr(type.rfind(',') + 1), "PR-655\r\n");
  EXPECT_EQ(ask(link, "M0\n"), "00000\r\n");
  for (const std::string report : {"D3\n", "D1\n", "D2\n"}) {
    const auto fields = lines_of(ask(link, report));
    ASSERT_EQ(fields.size(), 1u) << report;
    std::vector<std::string> parts;
    std::istringstream in(fields[0]);
    for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
    ASSERT_EQ(parts.size(), 5u) << report;
    for (std::size_t i = 2; i < 5; ++i) EXPECT_NO_THROW((void)std::stod(parts[i])) << report << " " << parts[i];
  }
  const auto spectrum = lines_of(ask(link, "D5\n"));
  ASSERT_EQ(spectrum.size(), 102u);
  for (std::size_t i = 2; i < spectrum.size(); ++i) {
    ASSERT_EQ(std::ranges::count(spectrum[i], ','), 1) << spectrum[i];
    EXPECT_TRUE(spectrum[i].ends_with('\r'));
  }
  const auto cct = lines_of(ask(link, "D4\n"));
  ASSERT_EQ(cct.size(), 1u);
  EXPECT_THAT(cct[0], ::testing::MatchesRegex("00000,0,[0-9.e+-]+, *[0-9]+,-?[0-9.]+\r")) << "a whole-number CCT";
  EXPECT_EQ(ask(link, "D110\n"), "00000,65500001\r\n");
  EXPECT_EQ(ask_expecting_silence(link, "Q"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
}

// Psychtoolbox's PR670 toolbox: every byte written alone, CR only where it belongs.
TEST(SimulatorPr6xx, ServesPsychtoolboxsPr670ByteByByte) {
  MeterRig rig(white_for(Model::pr670), options_for(Model::pr670));
  drivers::Transport& link = *rig.host();
  send_paced(link, "Q");
  send_paced(link, "PHOTO");
  EXPECT_EQ(testing::listen(link), " REMOTE MODE");
  send_paced(link, "D110\r");
  const std::string serial = testing::listen(link);
  ASSERT_GE(serial.size(), 6u + 8u);
  EXPECT_EQ(serial.substr(0, 6), "00000,");
  EXPECT_EQ(serial.substr(6, 8).find_first_of(" ,"), std::string::npos);
  send_paced(link, "F\r");
  double status = -1, hz = 0;
  EXPECT_EQ(std::sscanf(testing::listen(link).c_str(), "%lf,%lf", &status, &hz), 2);
  EXPECT_EQ(hz, 60);
  send_paced(link, "SS1\r");
  EXPECT_EQ(testing::listen(link), "0000\r\n");
  send_paced(link, "M5\r");
  const std::string reply = testing::listen(link);
  EXPECT_EQ(std::atof(reply.c_str()), 0.0);
  auto lines = lines_of(reply);
  lines.erase(lines.begin());
  ASSERT_EQ(lines.size(), 201u) << "exactly 201 lines after the header, nothing after them";
  EXPECT_EQ(lines[1].substr(0, 4), "382,");
  send_paced(link, "Q");
  EXPECT_EQ(testing::listen(link, std::chrono::milliseconds(30), std::chrono::milliseconds(150)), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
}

// ---- Faults ----------------------------------------------------------------------------------

TEST(SimulatorPr6xx, FastLossKeepsOnlyTheFirstByteOfAWholeString) {
  MeterRig rig(white_for(Model::pr655), options_for(Model::pr655, {"*:fast-loss=10"}));
  drivers::Transport& link = *rig.host();
  const auto send_slowly = [&](std::string_view bytes) {
    for (const char c : bytes) {
      (void)link.write(std::string_view(&c, 1), drivers::deadline_in(std::chrono::seconds(1)));
      std::this_thread::sleep_for(std::chrono::milliseconds(60));
    }
  };
  EXPECT_EQ(ask_expecting_silence(link, "PHOTO"), "") << "only the P survives";
  send_slowly("PHOTO");
  EXPECT_EQ(testing::listen(link), " REMOTE MODE");
  EXPECT_EQ(ask_expecting_silence(link, "D111\r"), "");
  send_slowly("\r");  // ends the lone "D" that survived: an unknown report
  EXPECT_EQ(testing::listen(link), "-2000\r\n");
  send_slowly("D111\r");
  EXPECT_EQ(testing::listen(link), "00000,PR-655\r\n");
}

TEST(SimulatorPr6xx, GlueHoldsTheBannerForTheNextReply) {
  MeterRig rig(white_for(Model::pr730), options_for(Model::pr730, {"photo:glue"}));
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "PHOTO"), "");
  EXPECT_EQ(ask(*rig.host(), "D111\r"), " REMOTE MODE00000,PR-730/735\r\n");
  EXPECT_EQ(ask(*rig.host(), "D111\r"), "00000,PR-730/735\r\n");
}

TEST(SimulatorPr6xx, LostPhotoAndLostQ) {
  MeterRig rig(white_for(Model::pr670), options_for(Model::pr670, {"photo:no-answer@1", "q:no-answer@1"}));
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "PHOTO"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), " REMOTE MODE");
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "Q"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::remote);
  EXPECT_EQ(ask_expecting_silence(*rig.host(), "Q"), "");
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
}

// A host that sends Q during a measurement and closes its port at once (as skinspecd does when
// it stops): the PR-670 has no abort, finishes, answers no one, and then leaves remote mode.
TEST(SimulatorPr6xx, QSentDuringAMeasurementByAHostThatLeftStillLeavesRemoteMode) {
  MeterOptions options = options_for(Model::pr670);
  using namespace std::chrono_literals;
  options.time_scale = 0.2;  // the measurement takes about 0.3 s
  MeterRig rig(white_for(Model::pr670), options);
  EXPECT_EQ(ask(*rig.host(), "PHOTO"), p6::kBanner);
  drivers::Transport& host = *rig.host();
  ASSERT_TRUE(host.write("M5\r", drivers::deadline_in(1s)));
  std::this_thread::sleep_for(50ms);
  ASSERT_TRUE(host.write(p6::kQuit, drivers::deadline_in(1s)));
  host.close();
  EXPECT_EQ(rig.wait_for_end(5s), SimulatedMeter::ServeEnd::closed);
  EXPECT_EQ(rig.meter().mode(), SimulatedMeter::Mode::local);
  const auto log = rig.log();
  EXPECT_NE(std::ranges::find(log, "command Q: remote mode left"), log.end()) << ::testing::PrintToString(log);
}

TEST(SimulatorPr6xx, TruncatedSpectrumAndMeasurementErrors) {
  Remote meter(Model::pr670, {"d5:truncate=100", "m5:error=-12@2", "p:error=-1"});
  EXPECT_EQ(ask(meter.link(), "M5\r").size(), 40u + 201 * 15) << "header and data lines whole";
  EXPECT_EQ(ask(meter.link(), "D5\r").size(), 100u);
  EXPECT_EQ(ask(meter.link(), "M5\r"), "-12\r\n");
  EXPECT_EQ(ask(meter.link(), "P\r"), "-1000\r\n") << "no P on a PR-670";
}

TEST(SimulatorPr6xx, NewFaultSpecsParseAndPrintBack) {
  for (const std::string text : {"*:fast-loss=20", "photo:glue", "m5:error=-8", "t:error=-1@1", "p:busy=3",
                                 "q:no-answer", "se:late=10", "photo:no-answer@1"}) {
    auto spec = parse_fault_spec(text);
    ASSERT_TRUE(spec) << text << ": " << spec.error();
    EXPECT_EQ(spec->to_string(), text);
  }
  EXPECT_FALSE(parse_fault_spec("m5:error=8"));
  EXPECT_FALSE(parse_fault_spec("*:fast-loss"));
  FaultSpec poll = *parse_fault_spec("p:busy");
  EXPECT_TRUE(poll.matches("p"));
  EXPECT_FALSE(poll.matches("photo")) << "p names the poll, not PHOTO";
}

// ---- Recordings ------------------------------------------------------------------------------

Recording load_recording(const std::string& name) {
  auto bytes = read_file(kRecordings + "/" + name);
  EXPECT_TRUE(bytes) << name;
  auto recording = parse_recording(bytes ? *bytes : std::string(), name);
  EXPECT_TRUE(recording) << recording.error();
  return recording ? *recording : Recording{};
}

TEST(SimulatorPr6xx, ManualExampleRecordingsReplayByteForByte) {
  for (const auto& [name, model] :
       {std::pair{"pr655-manual-examples.jsonl", Model::pr655}, std::pair{"pr670-manual-examples.jsonl", Model::pr670},
        std::pair{"pr730-manual-examples.jsonl", Model::pr730}}) {
    const Recording recording = load_recording(name);
    EXPECT_EQ(recording.header.model, model) << name;
    ASSERT_GE(recording.exchanges.size(), 8u) << name;
    MeterRig rig(recording);
    for (const Exchange& exchange : recording.exchanges) {
      const std::string rx =
          exchange.rx.empty() ? ask_expecting_silence(*rig.host(), exchange.tx) : ask(*rig.host(), exchange.tx);
      EXPECT_EQ(rx, exchange.rx) << name << ": " << exchange.tx;
    }
    EXPECT_TRUE(rig.meter().problems().empty()) << name << ": " << rig.meter().problems().front();
  }
}

// The synthetic meter agrees with the recorded examples where nothing depends on the scene.
TEST(SimulatorPr6xx, SyntheticMeterAgreesWithTheRecordedIdentityExchanges) {
  const Recording recording = load_recording("pr670-manual-examples.jsonl");
  MeterRig rig(white_for(Model::pr670), options_for(Model::pr670));
  for (const Exchange& exchange : recording.exchanges) {
    if (exchange.tx.starts_with("M")) break;  // from here on the values are the scene's
    const std::string rx =
        exchange.rx.empty() ? ask_expecting_silence(*rig.host(), exchange.tx) : ask(*rig.host(), exchange.tx);
    EXPECT_EQ(rx, exchange.rx) << exchange.tx;
  }
}

TEST(SimulatorPr6xx, RecordingsOfVersionTwoNameTheirModel) {
  Recording recording;
  recording.header.model = Model::pr735;
  recording.header.captured = "x";
  recording.exchanges.push_back({"PHOTO", " REMOTE MODE", 20, 1, {}, {}});
  const std::string text = format_recording(recording);
  EXPECT_THAT(text, ::testing::StartsWith(R"({"format":"skinspec-meter-recording","version":2,"model":"pr735",)"));
  auto back = parse_recording(text, "r.jsonl");
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->header.model, Model::pr735);
  EXPECT_EQ(format_recording(*back), text);

  auto v1 = parse_recording(R"({"format":"skinspec-pr650-recording","version":1,"captured":"x"})", "v1.jsonl");
  ASSERT_TRUE(v1) << v1.error();
  EXPECT_EQ(v1->header.model, Model::pr650);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"format":"skinspec-meter-recording","version":2,"captured":"x"})", "must name the \"model\""},
      {R"({"format":"skinspec-meter-recording","version":2,"model":"pr999","captured":"x"})",
       "\"pr999\" is not a model"},
      {R"({"format":"skinspec-pr650-recording","version":1,"model":"pr670","captured":"x"})", "a version 1 header"},
      {R"({"format":"skinspec-meter-recording","version":1,"model":"pr670","captured":"x"})", "version 1 is not one"},
  };
  for (const auto& [text_of, message] : bad) {
    auto parsed = parse_recording(text_of, "f.jsonl");
    ASSERT_FALSE(parsed) << text_of;
    EXPECT_THAT(parsed.error(), HasSubstr(message));
  }
}

TEST(SimulatorPr6xx, RecordingTransportCutsExchangesAtKeywords) {
  MeterRig rig(white_for(Model::pr670), options_for(Model::pr670));
  RecordingHeader header;
  header.model = Model::pr670;
  header.captured = "test";
  RecordingTransport recorder(rig.take_host(), header);
  send_paced(recorder, "PHOTO");
  (void)testing::listen(recorder);
  send_paced(recorder, "D111\r");
  (void)testing::listen(recorder);
  send_paced(recorder, "Q");
  const Recording recording = recorder.recording();
  ASSERT_EQ(recording.exchanges.size(), 3u);
  EXPECT_EQ(recording.exchanges[0].tx, "PHOTO");
  EXPECT_EQ(recording.exchanges[0].rx, " REMOTE MODE");
  EXPECT_EQ(recording.exchanges[1].tx, "D111\r");
  EXPECT_EQ(recording.exchanges[2].tx, "Q");
}

}  // namespace
}  // namespace skinspec::simulator
