// Writes the recordings of simulator/recordings/:
//   transcript-{a,b,c,d}.jsonl   the PR-650 protocol reference's example transcripts
//   synthetic-*.jsonl            driver sessions against the simulator, recorded through
//                                RecordingTransport (white standard and skin under illuminant A)
//
// Usage: make_recordings REFERENCE.md OUTPUT_DIR   (the data directory as skinspec finds it)

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "data_dir.hpp"
#include "skinspec/drivers/memory_transport.hpp"
#include "skinspec/drivers/pr650.hpp"
#include "skinspec/simulator/meter.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "transcripts.hpp"

namespace {

using namespace skinspec;
using namespace skinspec::simulator;
namespace fs = std::filesystem;

// The simulator runs this much faster than a real meter; recorded times are scaled back.
constexpr double kTimeScale = 0.05;

int fail(const std::string& message) {
  fmt::print(stderr, "make_recordings: {}\n", message);
  return 1;
}

bool write(const fs::path& path, const Recording& recording) {
  std::ofstream out(path, std::ios::binary);
  out << format_recording(recording);
  if (!out) return false;
  fmt::print("wrote {} ({} exchanges)\n", path.string(), recording.exchanges.size());
  return true;
}

struct Session {
  std::string file;
  std::string description;
  std::vector<Scene> scenes;
  std::vector<drivers::MeasureOptions> measurements;
};

// Runs the driver against a simulated meter, recording everything on the wire.
std::expected<Recording, std::string> record(const Session& session, const Observer& observer) {
  MeterOptions options;
  options.time_scale = kTimeScale;
  options.boot_window_s = 60;
  options.noise = 0.002;
  options.seed = 650;
  SimulatedMeter meter(Synthesis{observer, session.scenes}, options);
  auto [host, device] = drivers::make_memory_pair("memory");
  std::atomic<bool> stop{false};
  std::thread server([&, link = device.get()] { meter.serve(*link, stop); });

  RecordingHeader header;
  header.captured = fmt::format(
      "synthesized {:%Y-%m-%d}: the skinspec simulator at time scale {}, recorded through "
      "RecordingTransport (times scaled back to real time)",
      fmt::gmtime(std::time(nullptr)), kTimeScale);
  header.by = "make_recordings (skinspec simulator tools): the Pr650 driver's connect, identify and measure";
  header.description = session.description;
  header.boot_window_s = 5;
  header.header_variant = "H1";
  header.exponent = 'E';
  header.echo = false;
  auto recorder = std::make_unique<RecordingTransport>(std::move(host), header, RecordingOptions{kTimeScale});
  RecordingTransport* tap = recorder.get();
  drivers::DriverOptions driver_options;
  driver_options.modem_settle = std::chrono::milliseconds(0);
  drivers::Pr650 driver(std::move(recorder), driver_options);

  std::string error;
  if (auto connected = driver.connect(); !connected) error = "connect: " + connected.error().message;
  if (error.empty())
    if (auto identity = driver.identify(); !identity) error = "identify: " + identity.error().message;
  for (const auto& measure : session.measurements) {
    if (!error.empty()) break;
    auto reading = driver.measure(measure);
    fmt::print("  {}: {}\n", session.file,
               reading ? fmt::format("{:.4g} cd/m2, x {:.4f} y {:.4f}", reading->luminance, reading->x, reading->y)
                       : fmt::format("{} ({})", to_string(reading.error().kind), reading.error().message));
  }
  Recording recording = tap->recording();
  driver.disconnect();
  stop = true;
  server.join();
  if (!error.empty()) return std::unexpected(error);
  return recording;
}

Scene flat_white(const Lamp& lamp, const Observer& observer) {
  return scene_under_lamp("white standard (reflectance 0.99) under A", *Spectrum::create({380, 780}, {0.99, 0.99}),
                          lamp, observer);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return fail("usage: make_recordings REFERENCE.md OUTPUT_DIR");
  const fs::path reference = argv[1], out_dir = argv[2];

  auto markdown = read_file(reference);
  if (!markdown) return fail(markdown.error());
  auto transcripts = tools::transcripts_from_reference(*markdown, reference.filename().string());
  if (!transcripts) return fail(transcripts.error());
  for (const auto& [letter, recording] : *transcripts) {
    const std::string name = fmt::format("transcript-{}.jsonl", static_cast<char>(std::tolower(letter)));
    if (!write(out_dir / name, recording)) return fail("cannot write " + (out_dir / name).string());
  }

  const fs::path data = find_data_dir();
  auto colour = ColourData::load(directory_reader(data));
  if (!colour) return fail(colour.error());
  auto forearm = read_file(data / "examples" / "forearm.csv");
  if (!forearm) return fail(forearm.error());
  auto skins = parse_spectra_csv(*forearm, "examples/forearm.csv");
  if (!skins) return fail(skins.error().what());
  const auto& skin = (*skins)[1];  // the median skin of the three

  const Lamp bright{"A", colour->a, 150};
  const Lamp dim{"A", colour->a, 1.2};
  drivers::MeasureOptions adaptive;
  const std::vector<Session> sessions = {
      {"synthetic-white-and-skin-illuminant-a.jsonl",
       fmt::format("A white standard, then forearm skin ({} of data/examples/forearm.csv) under illuminant A, white "
                   "at {} cd/m2; adaptive integration, noise 0.2 %",
                   skin.name, bright.white_luminance),
       {flat_white(bright, colour->observer),
        scene_under_lamp(skin.name + " under A", skin.spectrum, bright, colour->observer)},
       {adaptive, adaptive}},
      {"synthetic-dim-skin-low-light.jsonl",
       fmt::format("The same white and skin under a dim illuminant A (white at {} cd/m2): the white measures, the skin "
                   "reads quality 18 and its D5 keeps the white's data lines (stale buffer)",
                   dim.white_luminance),
       {flat_white(dim, colour->observer),
        scene_under_lamp(skin.name + " under dim A", skin.spectrum, dim, colour->observer)},
       {adaptive, adaptive}},
  };
  for (const auto& session : sessions) {
    auto recording = record(session, colour->observer);
    if (!recording) return fail(session.file + ": " + recording.error());
    if (!write(out_dir / session.file, *recording)) return fail("cannot write " + (out_dir / session.file).string());
  }
  return 0;
}
