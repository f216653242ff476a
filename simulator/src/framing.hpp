#pragma once
// How the simulated meter cuts the bytes it receives into commands (private to simulator/).
// The PR-650 reads lines. The newer meters (PR-655 and later) listen in local mode for the
// keyword PHOTO alone, which needs no terminator; in remote mode Q acts at once, PHOTO is
// recognised (to be ignored) at its fifth byte, and every other command is a line ended by CR
// or LF (docs/simulator.md).

#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

namespace skinspec::simulator::detail {

struct Frame {
  enum class Kind {
    line,     // a command line, without its terminator
    photo,    // the keyword PHOTO
    quit,     // Q at the start of a line (newer meters)
    overflow  // a line longer than the meter's input buffer, dropped
  } kind = Kind::line;
  std::string text;
};

class Framer {
 public:
  virtual ~Framer() = default;
  // One received byte; `remote` says whether the meter is in remote mode.
  virtual std::optional<Frame> push(char byte, bool remote) = 0;
  // Bytes the meter has let pass without acting on them since the last call.
  virtual std::size_t take_ignored() { return 0; }
};

std::unique_ptr<Framer> make_line_framer();
std::unique_ptr<Framer> make_remote_framer();

// The fast-loss fault: a byte that arrives less than `gap` after the one before is lost, so
// of a command written in one go only its first byte survives.
class FastLoss {
 public:
  explicit FastLoss(std::chrono::milliseconds gap) : gap_(gap) {}
  // Of a chunk of bytes read at once (they arrived together), the bytes that survive.
  std::string filter(std::string_view chunk, std::chrono::steady_clock::time_point arrived);

 private:
  std::chrono::milliseconds gap_;
  std::optional<std::chrono::steady_clock::time_point> last_;
};

}  // namespace skinspec::simulator::detail
