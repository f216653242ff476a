#pragma once
// A scripted PR-650 on the far end of an in-process transport: it reads each command, checks
// it against the script, waits, and answers with the scripted bytes. For driver tests that
// need exact control of every byte and delay.

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::testing {

struct MeterStep {
  std::string command;                         // expected, lower case, without terminator
  std::string reply;                           // bytes to send back (may be empty: silence)
  std::chrono::milliseconds delay{0};          // before replying
  bool close_after = false;                    // then close the link, as an unplugged cable
  std::chrono::milliseconds line_interval{0};  // between the reply's lines: one streaming in
};

class ScriptedMeter {
 public:
  ScriptedMeter(std::unique_ptr<drivers::Transport> end, std::vector<MeterStep> script);
  ~ScriptedMeter();

  // Commands received, normalised (lower case, no terminator), in order.
  std::vector<std::string> commands() const;
  // Empty when every command matched the script so far; otherwise what went wrong.
  std::string mismatch() const;
  bool finished() const { return next_ >= script_.size(); }

 private:
  void run();
  void send(const MeterStep& step);
  bool read_command(std::string& command);

  std::unique_ptr<drivers::Transport> end_;
  std::vector<MeterStep> script_;
  std::atomic<std::size_t> next_{0};
  std::atomic<bool> stopping_{false};
  mutable std::mutex mutex_;
  std::vector<std::string> commands_;
  std::string mismatch_;
  std::string pending_;
  std::thread thread_;
};

}  // namespace skinspec::testing
