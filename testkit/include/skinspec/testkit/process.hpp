#pragma once
// Test helpers: run a program as a child process, feed it standard input and collect its
// standard output, standard error and exit status, killing it if it runs past a deadline; or
// start a long-running one (a server), watch what it writes while it runs, signal it, stop it;
// and read what the kernel says of any process.

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace skinspec::testing {

// What /proc/PID/stat says of a process: its state ('Z' for a zombie nobody has waited for
// yet), its parent, and its processor time in clock ticks (user and system), its own and its
// children's once it has waited for them.
struct ProcessStat {
  char state = '?';
  pid_t parent = 0;
  long long own_ticks = 0;
  long long children_ticks = 0;
};

// Nothing if the process is gone (or /proc cannot be read).
std::optional<ProcessStat> process_stat(pid_t pid);
// Clock ticks, as process_stat counts them, in seconds.
double ticks_to_seconds(long long ticks);

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

// A child that keeps running while the test talks to it, such as a server. Its standard input
// is /dev/null; a thread collects its standard output and standard error as they come, so it
// can never block on a full pipe, and a test can wait for a line it prints. Destroying the
// object kills the child (SIGKILL) if it is still running, and reaps it.
class BackgroundProcess {
 public:
  // Starts `program` (a path) with `args`; `options.environment` applies, `stdin_bytes` and
  // `timeout` do not. Whether it started: started(), and start_error() if not.
  BackgroundProcess(const std::string& program, const std::vector<std::string>& args,
                    const ProcessOptions& options = {});
  ~BackgroundProcess();
  BackgroundProcess(const BackgroundProcess&) = delete;
  BackgroundProcess& operator=(const BackgroundProcess&) = delete;

  bool started() const { return pid_ > 0; }
  const std::string& start_error() const { return start_error_; }
  pid_t pid() const { return pid_; }

  // The first complete line of standard output that starts with `prefix` (without its line
  // end), waiting up to `timeout` for it; nullopt if it did not come, or the child ended first.
  std::optional<std::string> wait_for_stdout_line(std::string_view prefix, std::chrono::milliseconds timeout);
  // Whether standard error came to contain `text` within `timeout`.
  bool wait_for_stderr(std::string_view text, std::chrono::milliseconds timeout);

  // Sends `signal` to the child, if it has not been reaped yet.
  void send_signal(int signal);
  // Waits for the child to end, killing it (SIGKILL, timed_out) after `timeout`, and returns
  // how it ended and all it wrote. Later calls return the same.
  ProcessResult wait(std::chrono::milliseconds timeout);
  // Whether the child has ended (reaping it if so), without waiting.
  bool has_exited();

  // What it has written so far.
  std::string out() const;
  std::string err() const;

 private:
  void collect(int out_fd, int err_fd);
  bool reap(bool block);

  pid_t pid_ = -1;
  std::string start_error_;
  bool reaped_ = false;
  ProcessResult result_;
  std::thread reader_;
  mutable std::mutex mutex_;  // out_, err_, outputs_closed_
  std::condition_variable changed_;
  std::string out_, err_;
  bool outputs_closed_ = false;
};

// A program's output split into its lines, without their line feeds.
std::vector<std::string> lines_of(const std::string& text);

}  // namespace skinspec::testing
