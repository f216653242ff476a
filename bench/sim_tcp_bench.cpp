// skinspec-sim as a separate process at time scale 0, reached over TCP on loopback as the
// driver reaches it in integration tests. Goal: an M0 + D5 exchange in <= 2 ms.
// Run from the build tree: build/release/bin/sim_tcp_bench (it starts build/release/bin/skinspec-sim).

#include <benchmark/benchmark.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/drivers/transport.hpp"

extern char** environ;

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "sim_tcp_bench: %s\n", message.c_str());
  std::exit(1);
}

// The simulator process, started beside this program, and the port it printed.
struct SimulatorProcess {
  pid_t pid = -1;
  std::string port;

  SimulatorProcess() {
    int out[2];
    if (pipe(out) != 0) die("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, out[0]);
    const std::string program = SKINSPEC_BENCH_BIN_DIR "/skinspec-sim";
    const char* argv[] = {program.c_str(), "--listen", "127.0.0.1:0", "--time-scale", "0",
                          "--boot-window", "inf",      "-q",          nullptr};
    if (posix_spawn(&pid, program.c_str(), &actions, nullptr, const_cast<char**>(argv), environ) != 0)
      die("cannot start " + program);
    posix_spawn_file_actions_destroy(&actions);
    close(out[1]);
    std::string line;
    char c;
    while (read(out[0], &c, 1) == 1 && c != '\n') line += c;
    close(out[0]);
    const auto colon = line.rfind(':');
    if (line.rfind("listening on ", 0) != 0 || colon == std::string::npos) die("unexpected first line '" + line + "'");
    port = line.substr(colon + 1);
  }
  ~SimulatorProcess() {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
  }
};

std::string exchange(Transport& link, const std::string& command, pr650::ReplyShape shape) {
  if (!link.write(command, deadline_in(1s))) die("write failed");
  std::string reply;
  char buffer[2048];
  while (!pr650::reply_complete(shape, reply)) {
    auto n = link.read(buffer, sizeof buffer, deadline_in(2s));
    if (!n) die("read failed: " + n.error().message);
    reply.append(buffer, *n);
  }
  return reply;
}

void M0_D5_OverTcp(benchmark::State& state) {
  SimulatorProcess simulator;
  auto uri = parse_connection_uri("tcp:127.0.0.1:" + simulator.port);
  auto link = make_transport(*uri);
  if (!link || !(*link)->open()) die("cannot connect to the simulator");
  exchange(**link, "b3\n", pr650::ReplyShape::line);
  for (auto _ : state) {
    benchmark::DoNotOptimize(exchange(**link, "m0\n", pr650::ReplyShape::line));
    benchmark::DoNotOptimize(exchange(**link, "d5\n", pr650::ReplyShape::spectral));
  }
}
BENCHMARK(M0_D5_OverTcp)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace
}  // namespace skinspec::drivers

BENCHMARK_MAIN();
