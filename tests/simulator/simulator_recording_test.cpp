// Recordings: the JSON-lines format, replay byte for byte, the reference's transcripts, and a
// driver session recorded and replayed with identical bytes.

#include "skinspec/simulator/recording.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <thread>

#include "skinspec/drivers/pr650.hpp"
#include "skinspec/simulator/meter.hpp"
#include "skinspec/simulator/simulator.hpp"
#include "support/simulator_rig.hpp"
#include "transcripts.hpp"

namespace skinspec::simulator {
namespace {

namespace pp = drivers::pr650;
using testing::ask;
using testing::fast_driver;
using testing::fast_meter;
using ::testing::HasSubstr;
using testing::MeterRig;

const std::string kRecordings = SKINSPEC_TEST_RECORDINGS_DIR;

Recording load(const std::string& name) {
  auto bytes = read_file(kRecordings + "/" + name);
  EXPECT_TRUE(bytes) << bytes.error();
  auto recording = parse_recording(bytes.value_or(""), name);
  EXPECT_TRUE(recording) << recording.error();
  return recording.value_or(Recording{});
}

// Sends each recorded command and expects exactly the recorded bytes back.
void expect_replayed_byte_for_byte(drivers::Transport& link, const Recording& recording) {
  for (std::size_t i = 0; i < recording.exchanges.size(); ++i) {
    const Exchange& e = recording.exchanges[i];
    EXPECT_EQ(ask(link, e.tx), e.rx) << "exchange " << i + 1 << ": " << e.tx;
  }
}

// ---- The format ----------------------------------------------------------------------------

TEST(RecordingFormat, EveryByteAndFieldSurvivesARoundTrip) {
  Recording r;
  r.header.captured = "2024-05-01 on /dev/ttyUSB0";
  r.header.by = "a test";
  r.header.description = "all 256 bytes";
  r.header.boot_window_s = 5;
  r.header.header_variant = "H2";
  r.header.exponent = 'e';
  r.header.echo = true;
  Exchange all;
  all.tx = "d5\n";
  for (int b = 0; b < 256; ++b) all.rx += static_cast<char>(b);
  all.delay_ms = 120;
  all.byte_interval_ms = 1.042;
  all.faults = {*parse_fault("truncate=100"), *parse_fault("header=h1")};
  all.note = "noise \u00e9";
  Exchange silent;
  silent.tx = "b3\r";
  silent.faults = {*parse_fault("late=20")};
  r.exchanges = {all, silent};

  const std::string text = format_recording(r);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3);
  auto back = parse_recording(text, "memory");
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->header.captured, r.header.captured);
  EXPECT_EQ(back->header.by, r.header.by);
  EXPECT_EQ(back->header.description, r.header.description);
  EXPECT_EQ(back->header.boot_window_s, 5);
  EXPECT_EQ(back->header.header_variant, "H2");
  EXPECT_EQ(back->header.exponent, 'e');
  EXPECT_EQ(back->header.echo, true);
  ASSERT_EQ(back->exchanges.size(), 2u);
  EXPECT_EQ(back->exchanges[0].rx, all.rx);
  EXPECT_EQ(back->exchanges[0].tx, "d5\n");
  EXPECT_EQ(back->exchanges[0].delay_ms, 120);
  EXPECT_EQ(back->exchanges[0].byte_interval_ms, 1.042);
  ASSERT_EQ(back->exchanges[0].faults.size(), 2u);
  EXPECT_EQ(back->exchanges[0].faults[1].to_string(), "header=h1");
  EXPECT_EQ(back->exchanges[0].note, all.note);
  EXPECT_EQ(back->exchanges[1].tx, "b3\r");
  EXPECT_EQ(back->exchanges[1].faults[0].to_string(), "late=20");
  EXPECT_EQ(format_recording(*back), text);
}

TEST(RecordingFormat, RefusesBadFilesNamingTheLine) {
  const std::string header = R"({"format":"skinspec-pr650-recording","version":1,"captured":"x","by":"y"})";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "empty: no header line"},
      {R"({"tx":"b3\n","rx":""})", "f.jsonl:1: the first line must be the header"},
      {R"({"format":"skinspec-pr650-recording","version":2,"captured":"x"})", "f.jsonl:1: version 2 is not one"},
      {R"({"format":"skinspec-pr650-recording","version":1,"by":"y"})", "must say how the session was \"captured\""},
      {R"({"format":"skinspec-pr650-recording","version":1,"captured":"x","colour":1})",
       "unknown header field \"colour\""},
      {header + "\n\n{\"tx\":\"b3\\n\"}", "f.jsonl:3: missing \"rx\""},
      {header + "\n{\"tx\":1,\"rx\":\"\"}", "f.jsonl:2: \"tx\" is not a string"},
      {header + "\n{\"tx\":\"b3\",\"rx\":\"\",\"delay\":1}", "unknown field \"delay\""},
      {header + "\n{\"tx\":\"b3\",\"rx\":\"\",\"delay_ms\":-1}", "\"delay_ms\" is not a number of milliseconds"},
      {header + "\n{\"tx\":\"b3\",\"rx\":\"\",\"fault\":\"oops\"}", "unknown fault 'oops'"},
      {header + "\n{\"tx\":\"b3\",\"rx\":\"\u20ac\"}", "above U+00FF"},
      {header + "\nnot json", "f.jsonl:2: not JSON"},
      {header + "\n[1,2]", "f.jsonl:2: not a JSON object"},
  };
  for (const auto& [text, message] : cases) {
    auto parsed = parse_recording(text, "f.jsonl");
    ASSERT_FALSE(parsed) << text;
    EXPECT_THAT(parsed.error(), HasSubstr(message)) << text;
  }
}

// ---- The stored recordings -------------------------------------------------------------------

TEST(Recordings, EveryStoredRecordingParses) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kRecordings)) {
    if (entry.path().extension() != ".jsonl") continue;
    const Recording r = load(entry.path().filename().string());
    EXPECT_FALSE(r.exchanges.empty()) << entry.path();
    EXPECT_FALSE(r.header.captured.empty()) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 6);
}

TEST(Recordings, TranscriptsMatchTheProtocolReference) {
  // The reference's section 6, as the project ships it (tests/data/pr650/README.md).
  auto markdown = read_file(std::string(PR650_TEST_DATA_DIR) + "/transcripts.md");
  ASSERT_TRUE(markdown) << markdown.error();
  auto transcripts = tools::transcripts_from_reference(*markdown, "transcripts.md");
  ASSERT_TRUE(transcripts) << transcripts.error();
  for (const auto& [letter, expected] : *transcripts) {
    const Recording stored = load(fmt::format("transcript-{}.jsonl", static_cast<char>(std::tolower(letter))));
    ASSERT_EQ(stored.exchanges.size(), expected.exchanges.size()) << letter;
    for (std::size_t i = 0; i < stored.exchanges.size(); ++i) {
      EXPECT_EQ(stored.exchanges[i].tx, expected.exchanges[i].tx) << letter << " " << i;
      EXPECT_EQ(stored.exchanges[i].rx, expected.exchanges[i].rx) << letter << " " << i;
    }
  }
}

TEST(Recordings, TranscriptAHasTheShapeTheReferenceDescribes) {
  const Recording a = load("transcript-a.jsonl");
  ASSERT_EQ(a.exchanges.size(), 6u);
  EXPECT_EQ(a.exchanges[3].tx, "d5\n");
  EXPECT_EQ(a.exchanges[3].rx.size(), 1733u);
  auto d5 = pp::parse_spectral(a.exchanges[3].rx);
  ASSERT_TRUE(d5) << d5.error().message;
  EXPECT_EQ(d5->values.size(), 101u);
  EXPECT_EQ(a.exchanges[2].delay_ms, 1500);
  EXPECT_EQ(a.header.header_variant, "H1");
}

// ---- Replay ----------------------------------------------------------------------------------

TEST(Replay, TranscriptAIsReplayedByteForByte) {
  const Recording a = load("transcript-a.jsonl");
  MeterRig rig(a);
  expect_replayed_byte_for_byte(*rig.host(), a);
  EXPECT_TRUE(rig.meter().problems().empty());
  EXPECT_EQ(testing::ask_expecting_silence(*rig.host(), "b3\n"), "");  // the recording is over
  EXPECT_THAT(rig.meter().problems().back(), HasSubstr("after the last of 6 recorded exchanges"));
}

TEST(Replay, EveryTranscriptIsReplayedByteForByte) {
  for (const char* name : {"transcript-b.jsonl", "transcript-c.jsonl", "transcript-d.jsonl",
                           "synthetic-white-and-skin-illuminant-a.jsonl", "synthetic-dim-skin-low-light.jsonl"}) {
    SCOPED_TRACE(name);
    const Recording r = load(name);
    MeterRig rig(r);
    expect_replayed_byte_for_byte(*rig.host(), r);
    EXPECT_TRUE(rig.meter().problems().empty());
  }
}

TEST(Replay, TheDriverReadsTranscriptAWhenReportsMayComeInAnyOrder) {
  MeterOptions options = fast_meter();
  options.replay_order = MeterOptions::ReplayOrder::by_command;
  MeterRig rig(load("transcript-a.jsonl"), options);
  auto driver = rig.driver();
  ASSERT_TRUE(driver->connect());
  auto reading = driver->measure({});
  ASSERT_TRUE(reading) << reading.error().message;
  EXPECT_EQ(reading->radiance.front(), 5.882e-05);
  EXPECT_EQ(reading->radiance.back(), 5.900e-05);
  EXPECT_EQ(reading->integrated, 0.3019);
  EXPECT_EQ(reading->luminance, 100);
  EXPECT_EQ(reading->x, 0.3355);
  EXPECT_EQ(reading->xyz[0], 102.6);
  EXPECT_TRUE(rig.meter().problems().empty());
}

TEST(Replay, ACommandOutOfOrderIsReportedClearlyAndGetsNoAnswer) {
  MeterRig rig(load("transcript-a.jsonl"));
  auto driver = rig.driver();
  ASSERT_TRUE(driver->connect());
  auto reading = driver->measure({});  // asks D1 before D2; transcript A has D2 first
  ASSERT_FALSE(reading);
  EXPECT_EQ(reading.error().kind, drivers::InstrumentError::Kind::lost);
  const auto problems = rig.meter().problems();
  ASSERT_FALSE(problems.empty());
  EXPECT_THAT(problems.front(), HasSubstr("replay mismatch at exchange 5 of 6: expected 'd2\\n', received 'D1'"));
}

TEST(Replay, TranscriptDIdentifiesThenStaysSilentLikeAMeterOutOfItsWindow) {
  MeterRig rig(load("transcript-d.jsonl"));
  auto driver = rig.driver();
  auto identity = driver->identify();
  ASSERT_TRUE(identity) << identity.error().message;
  EXPECT_EQ(identity->serial_number, "60912345");
  EXPECT_EQ(identity->configuration.points, 101);
  auto connected = driver->connect();
  ASSERT_FALSE(connected);
  EXPECT_EQ(connected.error().kind, drivers::InstrumentError::Kind::no_contact);
}

TEST(Replay, RecordedFaultsAndFaultSpecsActOnReplayedBytes) {
  Recording r = load("transcript-a.jsonl");
  r.exchanges[0].faults = {*parse_fault("truncate=2")};
  MeterOptions options = fast_meter();
  options.faults = *FaultPlan::parse(std::vector<std::string>{"m0:quality=8", "d5:exponent=e"});
  MeterRig rig(r, options);
  EXPECT_EQ(ask(*rig.host(), "b3\n"), "00");
  EXPECT_EQ(ask(*rig.host(), "s01,,,,,0,01,1\n"), "00\r\n");
  EXPECT_EQ(ask(*rig.host(), "m0\n"), "000\r\n");
  const std::string d5 = ask(*rig.host(), "d5\n");
  EXPECT_THAT(d5, ::testing::StartsWith("08,0\r3.019e-01\r\n0380.,5.882e-05"));
  EXPECT_THAT(ask(*rig.host(), "d2\n"), ::testing::StartsWith("08,0,"));
}

TEST(Replay, UnpromptedBytesAreSentWithoutACommand) {
  Recording r;
  r.header.captured = "test";
  Exchange hello;
  hello.rx = ">";
  Exchange b3;
  b3.tx = "b3\n";
  b3.rx = "000\r\n";
  r.exchanges = {hello, b3};
  MeterRig rig(r);
  EXPECT_EQ(testing::listen(*rig.host()), ">");
  EXPECT_EQ(ask(*rig.host(), "b3\n"), "000\r\n");
  EXPECT_TRUE(rig.meter().problems().empty());
}

// ---- Recording a session and replaying it ------------------------------------------------------

struct RecordedSession {
  Recording recording;
  std::vector<std::string> outcomes;  // per driver call: the reading's bytes or the error
};

// connect, identify, two measurements (one hit by a truncated report that the driver asks again
// for), and a measurement in low light.
RecordedSession run_session(ReadingSource source, MeterOptions options) {
  MeterRig rig(std::move(source), std::move(options));
  RecordingHeader header;
  header.captured = "test session";
  header.by = "simulator_recording_test";
  auto recorder = std::make_unique<RecordingTransport>(rig.take_host(), header);
  RecordingTransport* tap = recorder.get();
  drivers::Pr650 driver(std::move(recorder), fast_driver());
  RecordedSession out;
  const auto note = [&](const auto& result) {
    out.outcomes.push_back(result ? "ok" : std::string(to_string(result.error().kind)) + ": " + result.error().message);
  };
  note(driver.connect());
  auto identity = driver.identify();
  out.outcomes.push_back(identity ? identity->serial_number : identity.error().message);
  for (int i = 0; i < 3; ++i) {
    auto reading = driver.measure({});
    out.outcomes.push_back(reading ? reading->raw_reply
                                   : std::string(to_string(reading.error().kind)) + " " + reading.error().raw_reply);
  }
  out.recording = tap->recording();
  return out;
}

TEST(RecordAndReplay, ADriverSessionReplaysWithIdenticalBytes) {
  MeterOptions options = fast_meter();
  options.noise = 0.01;
  options.seed = 3;
  options.faults = *FaultPlan::parse(std::vector<std::string>{"d5:truncate@2"});
  Synthesis scenes{testing::observer(), {testing::white_scene(), testing::skin_scene(), testing::white_scene(0.5)}};
  const RecordedSession live = run_session(std::move(scenes), options);
  ASSERT_GE(live.recording.exchanges.size(), 15u);
  EXPECT_EQ(live.outcomes[0], "ok");

  // Through the file format and back, then replayed to the same driver calls.
  auto stored = parse_recording(format_recording(live.recording), "session.jsonl");
  ASSERT_TRUE(stored) << stored.error();
  const RecordedSession replayed = run_session(*stored, fast_meter());

  ASSERT_EQ(replayed.recording.exchanges.size(), live.recording.exchanges.size());
  for (std::size_t i = 0; i < live.recording.exchanges.size(); ++i) {
    EXPECT_EQ(replayed.recording.exchanges[i].tx, live.recording.exchanges[i].tx) << i;
    EXPECT_EQ(replayed.recording.exchanges[i].rx, live.recording.exchanges[i].rx) << i;
  }
  EXPECT_EQ(replayed.outcomes, live.outcomes);
  EXPECT_THAT(live.outcomes.back(), ::testing::StartsWith("bad_reading"));
}

TEST(RecordAndReplay, TheRecorderTimesEachReply) {
  // At a tenth of real time: a busy machine's pause of a few milliseconds is then a few tens of
  // the meter's, not hundreds as at 0.02.
  constexpr double kTimeScale = 0.1;
  MeterOptions options = fast_meter();
  options.time_scale = kTimeScale;
  MeterRig rig(Synthesis{testing::observer(), {testing::white_scene()}}, options);
  RecordingTransport recorder(rig.take_host(), RecordingHeader{"now", "test", {}, {}, {}, {}, {}},
                              RecordingOptions{kTimeScale});
  EXPECT_EQ(ask(recorder, "m0\n", std::chrono::milliseconds(100)), "000\r\n");
  EXPECT_EQ(ask(recorder, "d5\n", std::chrono::milliseconds(100)).size(), 1733u);
  const Recording r = recorder.recording();
  ASSERT_EQ(r.exchanges.size(), 2u);
  // The white's adaptive integration is about 0.8 s: with a dark one and overhead about 1.9 s.
  EXPECT_GT(r.exchanges[0].delay_ms, 1500);
  EXPECT_LT(r.exchanges[0].delay_ms, 4000);
  EXPECT_NEAR(r.exchanges[1].byte_interval_ms, kLineByteIntervalMs, 0.3);
}

// ---- Building a meter from a configuration -----------------------------------------------------

TEST(SimulatorConfig, BuildsFromFilesAndRefusesWhatDoesNotFit) {
  SimulatorConfig config;
  config.replay_file = kRecordings + "/transcript-a.jsonl";
  EXPECT_TRUE(make_simulated_meter(config));
  config.radiance_file = "x.csv";
  auto both = make_simulated_meter(config);
  ASSERT_FALSE(both);
  EXPECT_THAT(both.error(), HasSubstr("one source"));

  SimulatorConfig missing;
  missing.reflectance_files = {"/nonexistent/skin.csv"};
  auto error = make_simulated_meter(missing);
  ASSERT_FALSE(error);
  EXPECT_THAT(error.error(), HasSubstr("/nonexistent/skin.csv"));

  SimulatorConfig bad_fault;
  bad_fault.faults = {"d5:bogus"};
  auto fault = make_simulated_meter(bad_fault);
  ASSERT_FALSE(fault);
  EXPECT_THAT(fault.error(), HasSubstr("unknown fault 'bogus'"));

  SimulatorConfig lamp;
  lamp.illuminant = "F2";
  auto unknown = make_simulated_meter(lamp);
  ASSERT_FALSE(unknown);
  EXPECT_THAT(unknown.error(), HasSubstr("F2"));
}

TEST(SimulatorConfig, WhiteThenSkinUnderIlluminantA) {
  SimulatorConfig config;
  config.white_file = std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv";  // any reflectance will do
  config.reflectance_files = {std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv"};
  config.illuminant = "A";
  config.white_luminance = 200;
  config.meter = fast_meter();
  auto meter = make_simulated_meter(config);
  ASSERT_TRUE(meter) << meter.error();
  auto [host, device] = drivers::make_memory_pair();
  std::atomic<bool> stop{false};
  std::thread server([&] { (*meter)->serve(*device, stop); });
  drivers::Pr650 driver(std::move(host), fast_driver());
  ASSERT_TRUE(driver.connect());
  std::vector<double> luminance;
  for (int i = 0; i < 6; ++i) {
    auto reading = driver.measure({});
    ASSERT_TRUE(reading) << reading.error().message;
    luminance.push_back(reading->luminance);
  }
  driver.disconnect();
  stop = true;
  server.join();
  // Six columns in all (three in each file), in order: the lightest skin first each time.
  EXPECT_EQ(luminance[0], luminance[3]);
  EXPECT_GT(luminance[0], luminance[1]);
  EXPECT_GT(luminance[1], luminance[2]);
}

}  // namespace
}  // namespace skinspec::simulator
