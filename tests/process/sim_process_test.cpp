// The skinspec-sim program as a user runs it: real processes on loopback. The simulator is
// started in the background, the real `skinspec measure` (or a raw TCP or terminal client)
// talks to it, and the tests judge exit statuses, what each side printed, and the bytes on the
// wire. The meter's behaviour in depth (every fault against the driver) is simulator_test's.

#include <arpa/inet.h>
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "skinspec/testkit/process.hpp"

namespace skinspec {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

const std::string kSim = SKINSPEC_TEST_BIN_DIR "/skinspec-sim";
const std::string kSkinspec = SKINSPEC_TEST_BIN_DIR "/skinspec";
const std::string kForearm = SKINSPEC_TEST_DATA_DIR "/examples/forearm.csv";
const std::string kBusy = "skinspec-sim: busy: another client is connected\r\n";
constexpr int kBadInput = 2;
constexpr int kInstrumentError = 3;

// A descriptor that closes itself.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  Fd& operator=(Fd&&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

// A byte-level client over a socket or a terminal: writes whole strings, reads with deadlines.
class RawClient {
 public:
  explicit RawClient(Fd fd) : fd_(std::move(fd)) {}

  static std::optional<RawClient> connect_tcp(unsigned short port) {
    Fd fd(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    ::inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
    if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) return std::nullopt;
    return RawClient(std::move(fd));
  }

  // Opens the terminal's path and makes it raw, as a serial tool would.
  static std::optional<RawClient> open_terminal(const std::string& path) {
    Fd fd(::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC));
    if (fd.get() < 0) return std::nullopt;
    termios settings{};
    if (::tcgetattr(fd.get(), &settings) != 0) return std::nullopt;
    ::cfmakeraw(&settings);
    if (::tcsetattr(fd.get(), TCSANOW, &settings) != 0) return std::nullopt;
    return RawClient(std::move(fd));
  }

  bool send(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::write(fd_.get(), bytes.data(), bytes.size());
      if (n <= 0) return false;
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
  }

  // Reads until what was received ends with `ending`, the peer closes, or `timeout` passes;
  // returns everything received.
  std::string receive_until(std::string_view ending, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    std::string received;
    while (!received.ends_with(ending) || ending.empty()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) break;
      pollfd one{fd_.get(), POLLIN, 0};
      if (::poll(&one, 1, static_cast<int>(left)) <= 0) break;
      char buffer[4096];
      const ssize_t n = ::read(fd_.get(), buffer, sizeof buffer);
      if (n <= 0) {
        closed_ = true;
        break;
      }
      received.append(buffer, static_cast<std::size_t>(n));
    }
    return received;
  }

  // Everything until the peer closes (or `timeout`).
  std::string receive_all(std::chrono::milliseconds timeout) { return receive_until("", timeout); }

  // Whether the peer closed during the last receive.
  bool closed() const { return closed_; }

 private:
  Fd fd_;
  bool closed_ = false;
};

// skinspec-sim running in the background, on a port of its choosing.
struct Simulator {
  std::unique_ptr<testing::BackgroundProcess> process;
  unsigned short port = 0;
  std::string pty;  // with --pty: the terminal's path

  std::string device() const { return "tcp:127.0.0.1:" + std::to_string(port); }
};

// Starts skinspec-sim with `args` and waits for the lines it announces itself with: a port
// ("listening on 127.0.0.1:N") unless `tcp` is false, a terminal ("pty PATH") if `pty`.
Simulator start_simulator(std::vector<std::string> args, bool tcp = true, bool pty = false) {
  if (tcp) args.insert(args.begin(), {"--listen", "127.0.0.1:0"});
  if (pty) args.push_back("--pty");
  Simulator sim;
  sim.process = std::make_unique<testing::BackgroundProcess>(kSim, args);
  EXPECT_TRUE(sim.process->started()) << sim.process->start_error();
  if (tcp) {
    const auto line = sim.process->wait_for_stdout_line("listening on ", 20s);
    EXPECT_TRUE(line.has_value()) << "no address from skinspec-sim; stderr:\n" << sim.process->err();
    if (line) {
      const auto colon = line->rfind(':');
      EXPECT_EQ(line->substr(0, colon), "listening on 127.0.0.1");
      sim.port = static_cast<unsigned short>(std::stoi(line->substr(colon + 1)));
    }
  }
  if (pty) {
    const auto line = sim.process->wait_for_stdout_line("pty ", 20s);
    EXPECT_TRUE(line.has_value()) << "no terminal from skinspec-sim; stderr:\n" << sim.process->err();
    if (line) sim.pty = line->substr(4);
  }
  return sim;
}

testing::ProcessResult measure(const Simulator& sim, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args{"measure", "--device", sim.device(), "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  testing::ProcessOptions options;
  options.timeout = 60s;
  return testing::run_process(kSkinspec, args, options);
}

std::vector<Json> json_lines(const std::string& out) {
  std::vector<Json> parsed;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    parsed.push_back(Json::parse(line, nullptr, false));
    EXPECT_FALSE(parsed.back().is_discarded()) << "not JSON: " << line;
  }
  return parsed;
}

// SIGTERM, then the exit status it ends with; fails the test if it takes more than `limit`.
testing::ProcessResult terminate(Simulator& sim, std::chrono::milliseconds limit = 2s) {
  const auto start = Clock::now();
  sim.process->send_signal(SIGTERM);
  auto result = sim.process->wait(10s);
  EXPECT_LT(Clock::now() - start, limit) << "skinspec-sim took long to stop";
  return result;
}

// A fresh directory under the system's temporary directory, removed with everything in it.
class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("skinspec-sim-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::create_directories(path_);
  }
  ~TemporaryDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  std::string write(const std::string& name, const std::string& content) const {
    const auto file = path_ / name;
    std::ofstream(file, std::ios::binary) << content;
    return file.string();
  }

 private:
  std::filesystem::path path_;
};

TEST(SimProcess, MeasureOverTcpGivesTwoReadingsOfTheForearmFile) {
  auto sim = start_simulator({"--time-scale", "0", "--reflectance", kForearm});
  const auto result = measure(sim, {"--count", "2"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto readings = json_lines(result.out);
  ASSERT_EQ(readings.size(), 2u) << result.out;
  for (const auto& reading : readings) {
    EXPECT_EQ(reading["quality_code"], 0);
    EXPECT_EQ(reading["radiance"].size(), 101u);
    EXPECT_EQ(reading["wavelength_nm"].front(), 380.0);
    EXPECT_EQ(reading["wavelength_nm"].back(), 780.0);
    EXPECT_EQ(reading["serial"], "60912345");
  }
  // One scene per column, lightest skin first: the second reading is darker.
  EXPECT_GT(readings[0]["luminance"].get<double>(), readings[1]["luminance"].get<double>());
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

// A newer model over TCP: silent until PHOTO, its banner, identity and 2 nm spectrum, and Q.
TEST(SimProcess, Pr670OverTcpEntersRemoteModeAndMeasures) {
  Simulator sim = start_simulator({"--model", "pr670", "--time-scale", "0", "--reflectance", kForearm});
  auto client = RawClient::connect_tcp(sim.port);
  ASSERT_TRUE(client);
  ASSERT_TRUE(client->send("D111\r"));
  EXPECT_EQ(client->receive_all(300ms), "") << "silent outside remote mode";
  ASSERT_TRUE(client->send("PHOTO"));
  EXPECT_EQ(client->receive_until("MODE", 5s), " REMOTE MODE");
  ASSERT_TRUE(client->send("D111\r"));
  EXPECT_EQ(client->receive_until("\r\n", 5s), "00000,PR-670\r\n");
  ASSERT_TRUE(client->send("D120\r"));
  EXPECT_EQ(client->receive_until("\r\n", 5s), "00000,201,0.00,380,780,2,256,7,247\r\n");
  ASSERT_TRUE(client->send("SE0\r"));
  EXPECT_EQ(client->receive_until("\r\n", 5s), "0000\r\n");
  ASSERT_TRUE(client->send("M5\r"));
  const std::string spectrum = client->receive_until("780,", 10s) + client->receive_until("\r\n", 5s);
  EXPECT_THAT(spectrum, ::testing::StartsWith("00000,0,"));
  EXPECT_THAT(spectrum, HasSubstr("\r\n382,"));
  EXPECT_EQ(std::count(spectrum.begin(), spectrum.end(), '\n'), 202);
  ASSERT_TRUE(client->send("Q"));
  ASSERT_TRUE(client->send("D111\r"));
  EXPECT_EQ(client->receive_all(300ms), "") << "local again after Q";
  EXPECT_TRUE(sim.process->wait_for_stderr("command Q: remote mode left", 5s)) << sim.process->err();
}

TEST(SimProcess, StateCarriesOverFromOneClientToTheNext) {
  auto sim = start_simulator({"--time-scale", "0", "--reflectance", kForearm, "--serial", "60900001"});
  std::vector<double> luminances;
  for (int client = 0; client < 3; ++client) {
    const auto result = measure(sim);
    ASSERT_EQ(result.exit_status, 0) << result.describe();
    const auto readings = json_lines(result.out);
    ASSERT_EQ(readings.size(), 1u);
    EXPECT_EQ(readings[0]["serial"], "60900001");
    luminances.push_back(readings[0]["luminance"].get<double>());
  }
  // The three subjects of the file in turn, light to dark, not the first one three times.
  EXPECT_GT(luminances[0], luminances[1]);
  EXPECT_GT(luminances[1], luminances[2]);
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, WhiteStandardAndReflectanceUnderIlluminantA) {
  TemporaryDirectory dir;
  const std::string white = dir.write("white.csv", "wavelength_nm,white\n380,0.98\n780,0.98\n");
  auto sim = start_simulator({"--time-scale", "0", "--white", white, "--reflectance", kForearm, "--illuminant", "A",
                              "--white-luminance", "200"});
  const auto result = measure(sim, {"--count", "2"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto readings = json_lines(result.out);
  ASSERT_EQ(readings.size(), 2u);
  EXPECT_NEAR(readings[0]["luminance"].get<double>(), 196, 0.5);  // 0.98 x 200 cd/m2
  EXPECT_NEAR(readings[0]["x"].get<double>(), 0.4476, 0.001);     // illuminant A's chromaticity
  EXPECT_LT(readings[1]["luminance"].get<double>(), 100);         // skin reflects far less
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, ReplaysAStoredRecordingToTheRealDriver) {
  auto sim =
      start_simulator({"--time-scale", "0", "--replay",
                       SKINSPEC_TEST_SOURCE_DIR "/simulator/recordings/synthetic-white-and-skin-illuminant-a.jsonl"});
  const auto result = measure(sim, {"--count", "2"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_EQ(json_lines(result.out).size(), 2u);
  const auto ended = terminate(sim);
  EXPECT_EQ(ended.exit_status, 0);
  EXPECT_THAT(ended.err, ::testing::Not(HasSubstr("mismatch")));
}

TEST(SimProcess, QualityFaultEndsMeasureWithInstrumentError) {
  auto sim = start_simulator({"--time-scale", "0", "--fault", "d5:quality=19"});
  const auto result = measure(sim);
  EXPECT_EQ(result.exit_status, kInstrumentError) << result.describe();
  EXPECT_THAT(result.out, IsEmpty());
  EXPECT_THAT(result.err, HasSubstr("instrument error (bad_reading): quality 19"));
  EXPECT_TRUE(sim.process->wait_for_stderr("fault quality=19 on 'D5'", 5s)) << sim.process->err();
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, AMeasurementThatNeverAnsweredIsMadeAgainAndSaysSo) {
  // A fixed integration time: the wait for the lost M0 is 2 x 600 ms plus the overhead.
  auto sim = start_simulator({"--time-scale", "0", "--fault", "m0:no-answer@1", "--fault", "d1:garbage@1"});
  const auto result = measure(sim, {"--integration-ms", "600"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto readings = json_lines(result.out);
  ASSERT_EQ(readings.size(), 1u);
  EXPECT_EQ(readings[0]["attempts"], 2);
  ASSERT_EQ(readings[0]["warnings"].size(), 1u) << readings[0]["warnings"];
  EXPECT_TRUE(readings[0]["warnings"][0].get<std::string>().starts_with("remeasured: ")) << readings[0]["warnings"];
  EXPECT_THAT(result.err, HasSubstr("reading 1: remeasured: the PR-650 did not answer 'm0'"));
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, DisconnectFaultLosesTheMeterAndTheNextClientIsServed) {
  auto sim = start_simulator({"--time-scale", "0", "--fault", "d5:disconnect@1"});
  const auto lost = measure(sim);
  EXPECT_EQ(lost.exit_status, kInstrumentError) << lost.describe();
  EXPECT_THAT(lost.err, HasSubstr("instrument error (lost)"));
  EXPECT_THAT(lost.err, HasSubstr("'d5'"));
  const auto again = measure(sim);
  EXPECT_EQ(again.exit_status, 0) << again.describe();
  EXPECT_EQ(json_lines(again.out).size(), 1u);
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, SecondClientIsToldBusyWhileTheFirstIsServed) {
  auto sim = start_simulator({"--time-scale", "0"});
  auto first = RawClient::connect_tcp(sim.port);
  ASSERT_TRUE(first);
  ASSERT_TRUE(first->send("b3\n"));
  ASSERT_EQ(first->receive_until("\r\n", 5s), "000\r\n");  // the first client is being served

  auto second = RawClient::connect_tcp(sim.port);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->receive_all(5s), kBusy);
  EXPECT_TRUE(second->closed());

  // The first client never saw any of it, and is still served.
  ASSERT_TRUE(first->send("d110\n"));
  EXPECT_EQ(first->receive_until("\r\n", 5s), "60912345\r\n");
  first.reset();

  // With the first gone, the next client is served, by the same meter (already remote).
  std::string answer;
  for (auto until = Clock::now() + 5s; Clock::now() < until && answer != "000\r\n";) {
    auto third = RawClient::connect_tcp(sim.port);
    ASSERT_TRUE(third);
    ASSERT_TRUE(third->send("b3\n"));
    answer = third->receive_until("\r\n", 2s);
    if (answer == kBusy) std::this_thread::sleep_for(20ms);  // the first session may not have ended yet
  }
  EXPECT_EQ(answer, "000\r\n");
  const auto ended = terminate(sim);
  EXPECT_EQ(ended.exit_status, 0);
  EXPECT_THAT(ended.err, HasSubstr("refused, busy with client 127.0.0.1:"));
}

TEST(SimProcess, AClientRightAfterAProbeThatConnectedAndClosedIsServed) {
  // A readiness probe connects and closes; the real client connects at once after it, and
  // again after the previous client's close. Neither may be told the meter is busy.
  auto sim = start_simulator({"--time-scale", "0", "--radiance", kForearm});
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(RawClient::connect_tcp(sim.port)) << "probe " << i;  // closed at once
    auto client = RawClient::connect_tcp(sim.port);
    ASSERT_TRUE(client) << "client " << i;
    ASSERT_TRUE(client->send("b3\n"));
    ASSERT_EQ(client->receive_until("\r\n", 5s), "000\r\n") << "client " << i;
  }
  const auto ended = terminate(sim);
  EXPECT_EQ(ended.exit_status, 0);
  EXPECT_THAT(ended.err, ::testing::Not(HasSubstr("refused")));
}

TEST(SimProcess, SigtermStopsPromptlyWithAClientConnected) {
  auto sim = start_simulator({"--time-scale", "1"});
  auto client = RawClient::connect_tcp(sim.port);
  ASSERT_TRUE(client);
  ASSERT_TRUE(client->send("b3\n"));
  ASSERT_EQ(client->receive_until("\r\n", 5s), "000\r\n");
  ASSERT_TRUE(client->send("m0\n"));  // a measurement of about 2 s at time scale 1, cut short
  std::this_thread::sleep_for(50ms);
  const auto ended = terminate(sim, 1s);
  EXPECT_EQ(ended.exit_status, 0) << ended.describe();
  EXPECT_THAT(ended.err, HasSubstr("SIGTERM: stopping"));
  client->receive_all(2s);
  EXPECT_TRUE(client->closed());
}

TEST(SimProcess, SigintStopsWithStatus0AndNoLongerAccepts) {
  auto sim = start_simulator({"--time-scale", "0"});
  sim.process->send_signal(SIGINT);
  const auto ended = sim.process->wait(5s);
  EXPECT_EQ(ended.exit_status, 0) << ended.describe();
  EXPECT_FALSE(RawClient::connect_tcp(sim.port).has_value());
}

TEST(SimProcess, SighupPowerCyclesTheMeter) {
  auto sim = start_simulator({"--time-scale", "0", "--boot-window", "0.2"});
  std::this_thread::sleep_for(400ms);  // the power-on window has closed: the meter is in local mode
  auto client = RawClient::connect_tcp(sim.port);
  ASSERT_TRUE(client);
  ASSERT_TRUE(client->send("b3\n"));
  EXPECT_EQ(client->receive_until("\r\n", 500ms), "");
  ASSERT_TRUE(sim.process->wait_for_stderr("power-on window missed", 5s)) << sim.process->err();

  sim.process->send_signal(SIGHUP);
  ASSERT_TRUE(sim.process->wait_for_stderr("power-cycled: power-on window open", 5s)) << sim.process->err();
  ASSERT_TRUE(client->send("b3\n"));  // within the new window
  EXPECT_EQ(client->receive_until("\r\n", 5s), "000\r\n");
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, RestartedAfterSigkillOnANewPort) {
  auto first = start_simulator({"--time-scale", "0"});
  ASSERT_EQ(measure(first).exit_status, 0);
  first.process->send_signal(SIGKILL);
  const auto killed = first.process->wait(5s);
  EXPECT_EQ(killed.signal, SIGKILL);

  auto second = start_simulator({"--time-scale", "0"});
  ASSERT_NE(second.port, 0);
  const auto result = measure(second);
  EXPECT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_EQ(json_lines(result.out).size(), 1u);
  EXPECT_EQ(terminate(second).exit_status, 0);
}

TEST(SimProcess, PtyServesARawTerminalClient) {
  auto sim = start_simulator({"--time-scale", "0"}, /*tcp=*/false, /*pty=*/true);
  ASSERT_FALSE(sim.pty.empty());
  EXPECT_TRUE(std::filesystem::exists(sim.pty)) << sim.pty;
  {
    auto terminal = RawClient::open_terminal(sim.pty);
    ASSERT_TRUE(terminal) << sim.pty;
    ASSERT_TRUE(terminal->send("b3\n"));
    EXPECT_EQ(terminal->receive_until("\r\n", 5s), "000\r\n");
    ASSERT_TRUE(terminal->send("d110\r"));
    EXPECT_EQ(terminal->receive_until("\r\n", 5s), "60912345\r\n");
  }
  // Closed and opened again: a new session with the same meter.
  auto terminal = RawClient::open_terminal(sim.pty);
  ASSERT_TRUE(terminal);
  ASSERT_TRUE(terminal->send("b1\n"));
  EXPECT_EQ(terminal->receive_until("\r\n", 5s), "000\r\n");
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

TEST(SimProcess, PtyAndTcpShareOneMeterOneClientAtATime) {
  auto sim = start_simulator({"--time-scale", "0"}, /*tcp=*/true, /*pty=*/true);
  {
    auto terminal = RawClient::open_terminal(sim.pty);
    ASSERT_TRUE(terminal);
    ASSERT_TRUE(terminal->send("b3\n"));
    ASSERT_EQ(terminal->receive_until("\r\n", 5s), "000\r\n");
    auto tcp = RawClient::connect_tcp(sim.port);  // while the terminal is in session
    ASSERT_TRUE(tcp);
    EXPECT_EQ(tcp->receive_all(5s), kBusy);
  }
  // The terminal closed: TCP clients are served again.
  std::string answer;
  for (auto until = Clock::now() + 5s; Clock::now() < until && answer != "000\r\n";) {
    auto tcp = RawClient::connect_tcp(sim.port);
    ASSERT_TRUE(tcp);
    ASSERT_TRUE(tcp->send("b3\n"));
    answer = tcp->receive_until("\r\n", 2s);
    if (answer == kBusy) std::this_thread::sleep_for(20ms);
  }
  EXPECT_EQ(answer, "000\r\n");
  EXPECT_EQ(terminate(sim).exit_status, 0);
}

struct BadCase {
  std::vector<std::string> args;
  std::string message;
};

TEST(SimProcess, BadOptionsAndFilesExitWith2NamingTheProblem) {
  TemporaryDirectory dir;
  const std::string bad_csv = dir.write("bad.csv", "wavelength_nm,skin\n400,0.5\n550,abc\n700,0.5\n");
  const std::string missing = dir.write("present.csv", "") + ".missing";
  const std::vector<BadCase> cases = {
      {{}, "give --listen HOST:PORT, --pty, or both"},
      {{"--listen", "127.0.0.1"}, "--listen '127.0.0.1': no port"},
      {{"--listen", "127.0.0.1:70000"}, "the port is not a number 0-65535"},
      {{"--listen", "127.0.0.1:0", "--reflectance", missing}, missing + ": cannot open"},
      {{"--listen", "127.0.0.1:0", "--reflectance", bad_csv}, bad_csv + ":3:"},
      {{"--listen", "127.0.0.1:0", "--illuminant", missing}, missing},
      {{"--listen", "127.0.0.1:0", "--replay", bad_csv}, bad_csv + ":1:"},
      {{"--listen", "127.0.0.1:0", "--fault", "d5:trunc"}, "fault 'd5:trunc': unknown fault 'trunc'"},
      {{"--listen", "127.0.0.1:0", "--fault-rate", "1.5"}, "--fault-rate"},
      {{"--listen", "127.0.0.1:0", "--time-scale", "-1"}, "time scale -1 is negative"},
      {{"--listen", "127.0.0.1:0", "--boot-window", "soon"}, "--boot-window 'soon'"},
      {{"--listen", "127.0.0.1:0", "--header", "h3"}, "--header"},
      {{"--listen", "127.0.0.1:0", "--replay", bad_csv, "--radiance", bad_csv}, "--replay excludes --radiance"},
      {{"--listen", "127.0.0.1:0", "--frobnicate"}, "--frobnicate"},
  };
  for (const auto& c : cases) {
    testing::ProcessOptions options;
    options.timeout = 20s;
    const auto result = testing::run_process(kSim, c.args, options);
    EXPECT_EQ(result.exit_status, kBadInput) << ::testing::PrintToString(c.args) << "\n" << result.describe();
    EXPECT_THAT(result.err, HasSubstr(c.message)) << ::testing::PrintToString(c.args);
    EXPECT_THAT(result.out, IsEmpty()) << ::testing::PrintToString(c.args);
  }
}

TEST(SimProcess, HelpExitsWith0) {
  const auto result = testing::run_process(kSim, {"--help"});
  EXPECT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_THAT(result.out, HasSubstr("--listen"));
  EXPECT_THAT(result.out, HasSubstr("--pty"));
}

}  // namespace
}  // namespace skinspec
