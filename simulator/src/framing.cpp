#include "framing.hpp"

#include <cctype>
#include <string_view>
#include <utility>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::simulator::detail {

namespace {

constexpr std::size_t kMaxLine = 256;  // longer lines overflow the meter's input buffer

bool line_end(char byte) { return byte == '\r' || byte == '\n'; }

// Lines ended by CR or LF; empty lines (the LF of a CR LF) are nothing.
class LineFramer final : public Framer {
 public:
  std::optional<Frame> push(char byte, bool /*remote*/) override {
    if (!line_end(byte)) {
      line_ += byte;
      if (line_.size() <= kMaxLine) return std::nullopt;
      line_.clear();
      return Frame{Frame::Kind::overflow, {}};
    }
    if (line_.empty()) return std::nullopt;
    return Frame{Frame::Kind::line, std::exchange(line_, {})};
  }

 private:
  std::string line_;
};

class RemoteFramer final : public Framer {
 public:
  std::optional<Frame> push(char byte, bool remote) override {
    if (!remote) return local(byte);
    window_.clear();
    if (line_end(byte)) {
      if (line_.empty()) return std::nullopt;
      return Frame{Frame::Kind::line, std::exchange(line_, {})};
    }
    if (line_.empty() && (byte == 'Q' || byte == 'q')) return Frame{Frame::Kind::quit, "Q"};
    line_ += byte;
    if (line_ == drivers::pr6xx::kRemoteKeyword) return Frame{Frame::Kind::photo, std::exchange(line_, {})};
    if (line_.size() <= kMaxLine) return std::nullopt;
    line_.clear();
    return Frame{Frame::Kind::overflow, {}};
  }

  std::size_t take_ignored() override { return std::exchange(ignored_, 0); }

 private:
  // Local mode: only the five bytes of PHOTO in a row mean anything.
  std::optional<Frame> local(char byte) {
    line_.clear();
    window_ += byte;
    const std::string_view keyword = drivers::pr6xx::kRemoteKeyword;
    if (window_.size() > keyword.size()) window_.erase(0, window_.size() - keyword.size());
    if (window_ == keyword) {
      ignored_ -= std::min(ignored_, keyword.size() - 1);
      window_.clear();
      return Frame{Frame::Kind::photo, std::string(keyword)};
    }
    ++ignored_;
    return std::nullopt;
  }

  std::string line_;
  std::string window_;
  std::size_t ignored_ = 0;
};

}  // namespace

std::unique_ptr<Framer> make_line_framer() { return std::make_unique<LineFramer>(); }
std::unique_ptr<Framer> make_remote_framer() { return std::make_unique<RemoteFramer>(); }

std::string FastLoss::filter(std::string_view chunk, std::chrono::steady_clock::time_point arrived) {
  std::string kept;
  if (chunk.empty()) return kept;
  if (!last_ || arrived - *last_ >= gap_) kept += chunk.front();
  last_ = arrived;
  return kept;
}

}  // namespace skinspec::simulator::detail
