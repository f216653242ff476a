#pragma once
// Test helper: runs a program as a child process, feeds it standard input and collects its
// standard output, standard error and exit status, killing it if it runs past a deadline.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::testing {

struct ProcessOptions {
  // Bytes written to the child's standard input, which is then closed. Without them the
  // child reads /dev/null, so it can never block on the test program's own input.
  std::optional<std::string> stdin_bytes;
  // After this the child is killed (SIGKILL) and the result is marked timed_out.
  std::chrono::milliseconds timeout{std::chrono::seconds(120)};
  // "NAME=VALUE" entries added to (or overriding) the inherited environment.
  std::vector<std::string> environment;
};

struct ProcessResult {
  int exit_status = -1;  // the exit code when the child exited normally, else -1
  int signal = 0;        // the signal that ended the child, 0 when it exited normally
  bool timed_out = false;
  std::string out;  // everything written to standard output
  std::string err;  // everything written to standard error

  bool exited() const { return signal == 0 && exit_status >= 0; }
  // A one-paragraph account for assertion messages: how the child ended and what it wrote.
  std::string describe() const;
};

// Runs `program` (a path; not looked up in PATH) with `args` (argv[1...]). Failing to start
// the child at all is reported as exit status 127 with the reason in `err`, as a shell would.
ProcessResult run_process(const std::string& program, const std::vector<std::string>& args,
                          const ProcessOptions& options = {});

}  // namespace skinspec::testing
