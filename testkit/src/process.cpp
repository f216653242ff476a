#include "skinspec/testkit/process.hpp"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <utility>

extern char** environ;

namespace skinspec::testing {

std::optional<ProcessStat> process_stat(pid_t pid) {
  std::ifstream in(std::filesystem::path("/proc") / std::to_string(pid) / "stat");
  std::string line;
  if (!std::getline(in, line)) return std::nullopt;
  const auto name_end = line.rfind(')');  // the command's name, in parentheses, may hold anything
  if (name_end == std::string::npos) return std::nullopt;
  std::istringstream fields(line.substr(name_end + 1));
  ProcessStat stat;
  long long skipped = 0, utime = 0, stime = 0, cutime = 0, cstime = 0;
  fields >> stat.state >> stat.parent;  // fields 3 and 4 (a failure here fails the read below too)
  for (int field = 5; field <= 13; ++field) fields >> skipped;
  if (!(fields >> utime >> stime >> cutime >> cstime)) return std::nullopt;
  stat.own_ticks = utime + stime;
  stat.children_ticks = cutime + cstime;
  return stat;
}

double ticks_to_seconds(long long ticks) {
  return static_cast<double>(ticks) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

namespace {

using Clock = std::chrono::steady_clock;

// Owns a file descriptor and closes it when done with it.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(Fd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  Fd& operator=(Fd&& other) noexcept {
    if (this != &other) {
      close();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { close(); }

  int get() const { return fd_; }
  bool is_open() const { return fd_ >= 0; }
  int release() { return std::exchange(fd_, -1); }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

struct Pipe {
  Fd read, write;
};

// Close-on-exec, so that only the ends dup2'ed onto 0, 1 and 2 reach the child and an EOF
// is not held up by a copy leaked into it (or into a child started by another thread).
bool make_pipe(Pipe& pipe) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return false;
  pipe.read = Fd(fds[0]);
  pipe.write = Fd(fds[1]);
  return true;
}

// A child that stops reading its input early must not kill the test program with SIGPIPE
// while we write the rest; the failed write then reports EPIPE instead.
void ignore_sigpipe_once() {
  static const bool done = [] {
    std::signal(SIGPIPE, SIG_IGN);
    return true;
  }();
  (void)done;
}

std::string name_of(const std::string& entry) { return entry.substr(0, entry.find('=')); }

// The inherited environment with `overrides` replacing variables of the same name.
std::vector<std::string> child_environment(const std::vector<std::string>& overrides) {
  std::vector<std::string> env;
  for (char** e = environ; e && *e; ++e) {
    const std::string entry(*e);
    bool overridden = false;
    for (const auto& o : overrides) overridden = overridden || name_of(o) == name_of(entry);
    if (!overridden) env.push_back(entry);
  }
  env.insert(env.end(), overrides.begin(), overrides.end());
  return env;
}

// posix_spawn wants mutable, null-terminated char* arrays; these point into `strings`.
std::vector<char*> c_array(std::vector<std::string>& strings) {
  std::vector<char*> out;
  for (auto& s : strings) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

// Wires the child's 0, 1 and 2 to the pipes (or 0 to /dev/null) and restores the default
// SIGPIPE the test program ignores, so the child behaves as it would from a shell.
class SpawnSetup {
 public:
  SpawnSetup(const Pipe* input, const Pipe& output, const Pipe& error) {
    posix_spawn_file_actions_init(&actions_);
    if (input) posix_spawn_file_actions_adddup2(&actions_, input->read.get(), STDIN_FILENO);
    else posix_spawn_file_actions_addopen(&actions_, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions_, output.write.get(), STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions_, error.write.get(), STDERR_FILENO);

    posix_spawnattr_init(&attributes_);
    sigset_t defaults, empty;
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGPIPE);
    sigemptyset(&empty);
    posix_spawnattr_setsigdefault(&attributes_, &defaults);
    posix_spawnattr_setsigmask(&attributes_, &empty);
    posix_spawnattr_setflags(&attributes_, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  }
  SpawnSetup(const SpawnSetup&) = delete;
  SpawnSetup& operator=(const SpawnSetup&) = delete;
  ~SpawnSetup() {
    posix_spawn_file_actions_destroy(&actions_);
    posix_spawnattr_destroy(&attributes_);
  }

  const posix_spawn_file_actions_t* actions() const { return &actions_; }
  const posix_spawnattr_t* attributes() const { return &attributes_; }

 private:
  posix_spawn_file_actions_t actions_;
  posix_spawnattr_t attributes_;
};

// Appends what is ready on `fd` to `sink`; closes `fd` at end of file or on an error.
void drain(Fd& fd, std::string& sink) {
  char buffer[65536];
  const ssize_t n = ::read(fd.get(), buffer, sizeof buffer);
  if (n > 0) sink.append(buffer, static_cast<std::size_t>(n));
  else if (n == 0 || (errno != EINTR && errno != EAGAIN)) fd.close();
}

// Writes as much of `bytes` from `offset` as the pipe takes; closes `fd` when all is written
// or the child has closed its end (EPIPE), which is the child's business, not an error here.
void feed(Fd& fd, const std::string& bytes, std::size_t& offset) {
  if (offset < bytes.size()) {
    const ssize_t n = ::write(fd.get(), bytes.data() + offset, bytes.size() - offset);
    if (n > 0) offset += static_cast<std::size_t>(n);
    else if (n < 0 && errno != EINTR && errno != EAGAIN) offset = bytes.size();
  }
  if (offset >= bytes.size()) fd.close();
}

int milliseconds_until(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<std::chrono::milliseconds::rep>(0, left.count()));
}

// Moves bytes between the pipes and the result until the child closes its output or the
// deadline passes. Returns false on the deadline.
bool exchange_until(Clock::time_point deadline, Fd& input, const std::string& input_bytes, Fd& output, Fd& error,
                    ProcessResult& result) {
  std::size_t written = 0;
  if (input.is_open()) feed(input, input_bytes, written);
  while (output.is_open() || error.is_open()) {
    pollfd fds[3] = {{output.get(), POLLIN, 0}, {error.get(), POLLIN, 0}, {input.get(), POLLOUT, 0}};
    const int ready = ::poll(fds, 3, milliseconds_until(deadline));  // negative fds are skipped
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) return false;
    if (fds[0].revents) drain(output, result.out);
    if (fds[1].revents) drain(error, result.err);
    if (fds[2].revents) feed(input, input_bytes, written);
  }
  return true;
}

// Reaps the child, killing it if it has not ended by the deadline.
void reap(pid_t pid, Clock::time_point deadline, ProcessResult& result) {
  int status = 0;
  while (true) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) return;
    if (Clock::now() >= deadline && !result.timed_out) {
      result.timed_out = true;
      ::kill(pid, SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (WIFEXITED(status)) result.exit_status = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) result.signal = WTERMSIG(status);
}

std::string clipped(const std::string& text) {
  constexpr std::size_t kLimit = 4000;
  return text.size() <= kLimit
             ? text
             : text.substr(0, kLimit) + "\n[... " + std::to_string(text.size() - kLimit) + " more bytes]";
}

}  // namespace

std::string ProcessResult::describe() const {
  std::string how = timed_out     ? "timed out and was killed"
                    : signal != 0 ? "was killed by signal " + std::to_string(signal)
                                  : "exited with status " + std::to_string(exit_status);
  return "the child " + how + "\n--- stdout ---\n" + clipped(out) + "\n--- stderr ---\n" + clipped(err);
}

ProcessResult run_process(const std::string& program, const std::vector<std::string>& args,
                          const ProcessOptions& options) {
  ignore_sigpipe_once();
  ProcessResult result;
  Pipe input, output, error;
  const bool has_input = options.stdin_bytes.has_value();
  if ((has_input && !make_pipe(input)) || !make_pipe(output) || !make_pipe(error)) {
    result.exit_status = 127;
    result.err = std::string("cannot create a pipe: ") + std::strerror(errno);
    return result;
  }

  std::vector<std::string> argv_strings{program};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  auto env_strings = child_environment(options.environment);
  auto argv = c_array(argv_strings);
  auto envp = c_array(env_strings);

  pid_t pid = 0;
  const int spawned = [&] {
    const SpawnSetup setup(has_input ? &input : nullptr, output, error);
    return ::posix_spawn(&pid, program.c_str(), setup.actions(), setup.attributes(), argv.data(), envp.data());
  }();
  if (spawned != 0) {
    result.exit_status = 127;
    result.err = "cannot start " + program + ": " + std::strerror(spawned);
    return result;
  }
  // Our copies of the child's ends: left open, they would keep its output from reaching EOF.
  input.read.close();
  output.write.close();
  error.write.close();
  if (input.write.is_open()) ::fcntl(input.write.get(), F_SETFL, O_NONBLOCK);

  const auto deadline = Clock::now() + options.timeout;
  if (!exchange_until(deadline, input.write, options.stdin_bytes.value_or(""), output.read, error.read, result)) {
    result.timed_out = true;
    ::kill(pid, SIGKILL);
  }
  reap(pid, deadline, result);
  return result;
}

namespace {

// The complete lines of `text` (without CR LF or LF), in order.
std::vector<std::string_view> complete_lines(std::string_view text) {
  std::vector<std::string_view> lines;
  std::size_t start = 0;
  for (std::size_t end = text.find('\n'); end != std::string_view::npos; end = text.find('\n', start)) {
    std::string_view line = text.substr(start, end - start);
    start = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
  }
  return lines;
}

}  // namespace

BackgroundProcess::BackgroundProcess(const std::string& program, const std::vector<std::string>& args,
                                     const ProcessOptions& options) {
  ignore_sigpipe_once();
  Pipe output, error;
  if (!make_pipe(output) || !make_pipe(error)) {
    start_error_ = std::string("cannot create a pipe: ") + std::strerror(errno);
    return;
  }
  std::vector<std::string> argv_strings{program};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  auto env_strings = child_environment(options.environment);
  auto argv = c_array(argv_strings);
  auto envp = c_array(env_strings);
  pid_t pid = 0;
  const int spawned = [&] {
    const SpawnSetup setup(nullptr, output, error);
    return ::posix_spawn(&pid, program.c_str(), setup.actions(), setup.attributes(), argv.data(), envp.data());
  }();
  if (spawned != 0) {
    start_error_ = "cannot start " + program + ": " + std::strerror(spawned);
    return;
  }
  pid_ = pid;
  output.write.close();
  error.write.close();
  reader_ = std::thread([this, out = output.read.release(), err = error.read.release()] { collect(out, err); });
}

BackgroundProcess::~BackgroundProcess() {
  if (pid_ > 0 && !reap(false)) {
    ::kill(pid_, SIGKILL);
    reap(true);
  }
  if (reader_.joinable()) reader_.join();
}

void BackgroundProcess::collect(int out_fd, int err_fd) {
  Fd out(out_fd), err(err_fd);
  while (out.is_open() || err.is_open()) {
    pollfd fds[2] = {{out.get(), POLLIN, 0}, {err.get(), POLLIN, 0}};
    const int ready = ::poll(fds, 2, -1);
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) break;
    std::string more_out, more_err;
    if (fds[0].revents) drain(out, more_out);
    if (fds[1].revents) drain(err, more_err);
    {
      std::lock_guard lock(mutex_);
      out_ += more_out;
      err_ += more_err;
    }
    changed_.notify_all();
  }
  {
    std::lock_guard lock(mutex_);
    outputs_closed_ = true;
  }
  changed_.notify_all();
}

std::optional<std::string> BackgroundProcess::wait_for_stdout_line(std::string_view prefix,
                                                                   std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  std::unique_lock lock(mutex_);
  for (;;) {
    for (const auto line : complete_lines(out_))
      if (line.starts_with(prefix)) return std::string(line);
    if (outputs_closed_ || Clock::now() >= deadline) return std::nullopt;
    changed_.wait_until(lock, deadline);
  }
}

bool BackgroundProcess::wait_for_stderr(std::string_view text, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return err_.find(text) != std::string::npos || outputs_closed_; }) &&
         err_.find(text) != std::string::npos;
}

void BackgroundProcess::send_signal(int signal) {
  if (pid_ > 0 && !reaped_) ::kill(pid_, signal);
}

bool BackgroundProcess::reap(bool block) {
  if (reaped_ || pid_ <= 0) return reaped_;
  int status = 0;
  pid_t done = 0;
  do {
    done = ::waitpid(pid_, &status, block ? 0 : WNOHANG);
  } while (done < 0 && errno == EINTR);
  if (done != pid_) return false;
  reaped_ = true;
  if (WIFEXITED(status)) result_.exit_status = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) result_.signal = WTERMSIG(status);
  return true;
}

bool BackgroundProcess::has_exited() { return reap(false); }

ProcessResult BackgroundProcess::wait(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) {
    ProcessResult failed;
    failed.exit_status = 127;
    failed.err = start_error_;
    return failed;
  }
  const auto deadline = Clock::now() + timeout;
  while (!reap(false)) {
    if (Clock::now() >= deadline) {
      result_.timed_out = true;
      ::kill(pid_, SIGKILL);
      reap(true);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (reader_.joinable()) reader_.join();
  std::lock_guard lock(mutex_);
  result_.out = out_;
  result_.err = err_;
  return result_;
}

std::string BackgroundProcess::out() const {
  std::lock_guard lock(mutex_);
  return out_;
}

std::string BackgroundProcess::err() const {
  std::lock_guard lock(mutex_);
  return err_;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace skinspec::testing
