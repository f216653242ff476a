#include "support/scripted_meter.hpp"

#include <algorithm>
#include <cctype>

namespace skinspec::testing {

using namespace std::chrono_literals;

ScriptedMeter::ScriptedMeter(std::unique_ptr<drivers::Transport> end, std::vector<MeterStep> script)
    : end_(std::move(end)), script_(std::move(script)) {
  (void)end_->open();
  thread_ = std::thread([this] { run(); });
}

ScriptedMeter::~ScriptedMeter() {
  stopping_ = true;
  end_->interrupt();
  thread_.join();
}

std::vector<std::string> ScriptedMeter::commands() const {
  std::lock_guard lock(mutex_);
  return commands_;
}

std::string ScriptedMeter::mismatch() const {
  std::lock_guard lock(mutex_);
  return mismatch_;
}

// A command ends at CR or LF; empty lines (the second half of a CRLF) are skipped.
bool ScriptedMeter::read_command(std::string& command) {
  char buffer[256];
  while (!stopping_) {
    const auto end = pending_.find_first_of("\r\n");
    if (end != std::string::npos) {
      command = pending_.substr(0, end);
      pending_.erase(0, end + 1);
      if (command.empty()) continue;
      std::ranges::transform(command, command.begin(),
                             [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      return true;
    }
    auto n = end_->read(buffer, sizeof buffer, drivers::deadline_in(100ms));
    if (n) {
      pending_.append(buffer, *n);
    } else if (n.error().kind != drivers::TransportError::Kind::timeout) {
      return false;
    }
  }
  return false;
}

void ScriptedMeter::send(const MeterStep& step) {
  if (step.line_interval == 0ms) {
    if (!step.reply.empty()) (void)end_->write(step.reply, drivers::deadline_in(1s));
    return;
  }
  for (std::size_t at = 0; at < step.reply.size() && !stopping_;) {
    const std::size_t end = std::min(step.reply.find('\n', at), step.reply.size() - 1) + 1;
    (void)end_->write(std::string_view(step.reply).substr(at, end - at), drivers::deadline_in(1s));
    at = end;
    if (at < step.reply.size()) std::this_thread::sleep_for(step.line_interval);
  }
}

void ScriptedMeter::run() {
  std::string command;
  while (read_command(command)) {
    const std::size_t index = next_;
    {
      std::lock_guard lock(mutex_);
      commands_.push_back(command);
      if (index >= script_.size()) {
        if (mismatch_.empty()) mismatch_ = "unexpected extra command '" + command + "'";
        continue;
      }
      if (command != script_[index].command && mismatch_.empty())
        mismatch_ =
            "step " + std::to_string(index) + ": expected '" + script_[index].command + "', got '" + command + "'";
    }
    const MeterStep& step = script_[index];
    for (auto waited = 0ms; waited < step.delay && !stopping_; waited += 5ms) std::this_thread::sleep_for(5ms);
    send(step);
    next_ = index + 1;
    if (step.close_after) {
      end_->close();
      return;
    }
  }
}

}  // namespace skinspec::testing
