#include "transcripts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <optional>
#include <vector>

namespace skinspec::simulator::tools {

namespace {

constexpr std::string_view kHeading = "### Transcript ";
constexpr double kDefaultDelayMs = 50, kMeasureDelayMs = 1500, kFlickerDelayMs = 1000;

std::string_view trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  return text;
}

std::vector<std::string_view> lines_of(std::string_view text) {
  std::vector<std::string_view> lines;
  while (!text.empty()) {
    const auto lf = text.find('\n');
    lines.push_back(text.substr(0, lf));
    text.remove_prefix(lf == std::string_view::npos ? text.size() : lf + 1);
  }
  return lines;
}

// A C-escaped string literal at the start of `text`: its bytes, and what follows it.
std::optional<std::pair<std::string, std::string_view>> literal(std::string_view text) {
  if (text.empty() || text.front() != '"') return std::nullopt;
  std::string bytes;
  for (std::size_t i = 1; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') return std::pair{bytes, text.substr(i + 1)};
    if (c != '\\' || i + 1 >= text.size()) {
      bytes += c;
      continue;
    }
    const char e = text[++i];
    switch (e) {
      case 'r':
        bytes += '\r';
        break;
      case 'n':
        bytes += '\n';
        break;
      case 't':
        bytes += '\t';
        break;
      case 'x':
        if (i + 2 < text.size()) {
          bytes += static_cast<char>(std::stoi(std::string(text.substr(i + 1, 2)), nullptr, 16));
          i += 2;
        }
        break;
      default:
        bytes += e;
        break;
    }
  }
  return std::nullopt;
}

// "~1.5 s", "~50 ms" or "10 s" in a timing note, in milliseconds.
std::optional<double> time_in(std::string_view note) {
  for (std::size_t i = 0; i < note.size(); ++i) {
    const auto at = [&](std::size_t k) { return static_cast<unsigned char>(note[k]); };
    // A number starts here, not inside a word or another number ("9600-8-N-1").
    if (!std::isdigit(at(i)) || (i > 0 && (std::isalnum(at(i - 1)) || note[i - 1] == '.' || note[i - 1] == '-')))
      continue;
    std::size_t j = i;
    while (j < note.size() && (std::isdigit(static_cast<unsigned char>(note[j])) || note[j] == '.')) ++j;
    const double value = std::stod(std::string(note.substr(i, j - i)));
    std::string_view unit = note.substr(j);
    if (unit.starts_with(' ')) unit.remove_prefix(1);
    const auto word_end = [&](std::size_t n) {
      return unit.size() == n || !std::isalpha(static_cast<unsigned char>(unit[n]));
    };
    if (unit.starts_with("ms") && word_end(2)) return value;
    if (unit.starts_with("s") && word_end(1)) return value * 1000;
    i = j;
  }
  return std::nullopt;
}

double default_delay(std::string_view tx) {
  const char c = tx.empty() ? ' ' : static_cast<char>(std::tolower(static_cast<unsigned char>(tx.front())));
  if (c == 'm') return kMeasureDelayMs;
  if (c == 'f') return kFlickerDelayMs;
  return kDefaultDelayMs;
}

void add_note(std::string& into, std::string_view note) {
  note = trim(note);
  if (note.size() >= 2 && note.front() == '(' && note.back() == ')') note = note.substr(1, note.size() - 2);
  if (note.empty()) return;
  if (!into.empty()) into += "; ";
  into += note;
}

struct Block {
  char letter;
  std::string title;
  std::vector<std::string_view> lines;
};

std::vector<Block> blocks_of(std::string_view markdown) {
  std::vector<Block> blocks;
  const auto lines = lines_of(markdown);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (!lines[i].starts_with(kHeading) || lines[i].size() <= kHeading.size()) continue;
    Block block{lines[i][kHeading.size()], std::string(trim(lines[i].substr(kHeading.size() + 1))), {}};
    std::size_t j = i + 1;
    while (j < lines.size() && !lines[j].starts_with("```")) ++j;
    for (++j; j < lines.size() && !lines[j].starts_with("```"); ++j) block.lines.push_back(lines[j]);
    blocks.push_back(std::move(block));
    i = j;
  }
  return blocks;
}

// The data lines of a spectral reply (everything after its header).
std::string data_lines(std::string_view d5) {
  const auto at = d5.find("0380.,");
  return at == std::string_view::npos ? std::string() : std::string(d5.substr(at));
}

std::expected<Recording, std::string> read_block(const Block& block, std::string_view source, const std::string& a_d5) {
  Recording recording;
  recording.header.captured =
      fmt::format("synthesized: transcript {} of {} (section 6); no recording of a real PR-650 exchange is public",
                  block.letter, source);
  recording.header.by = "make_recordings (skinspec simulator tools), from the reference's TX/RX lines";
  recording.header.description =
      fmt::format("Transcript {}{}", block.letter, block.title.empty() ? "" : " " + block.title);
  recording.header.boot_window_s = 5;
  recording.header.exponent = 'E';
  recording.header.echo = false;
  std::string pending_note;
  bool delay_given = false;
  auto& exchanges = recording.exchanges;
  const auto finish = [&] {
    if (!exchanges.empty() && !delay_given) exchanges.back().delay_ms = default_delay(exchanges.back().tx);
  };
  for (const std::string_view raw : block.lines) {
    const std::string_view line = trim(raw);
    if (line.starts_with("TX")) {
      auto tx = literal(trim(line.substr(2)));
      if (!tx) return std::unexpected(fmt::format("transcript {}: cannot read '{}'", block.letter, line));
      finish();
      exchanges.emplace_back().tx = tx->first;
      exchanges.back().byte_interval_ms = 1.042;
      delay_given = false;
      add_note(exchanges.back().note, trim(tx->second));
      if (!pending_note.empty()) {
        add_note(exchanges.back().note, pending_note);
        pending_note.clear();
      }
    } else if (line.starts_with("RX")) {
      if (exchanges.empty()) return std::unexpected(fmt::format("transcript {}: RX before any TX", block.letter));
      Exchange& exchange = exchanges.back();
      const std::string_view rest = trim(line.substr(2));
      if (rest.starts_with("(same as transcript A's D5 reply)")) {
        exchange.rx += a_d5;
        add_note(exchange.note, "the same reply as transcript A's D5");
        continue;
      }
      auto rx = literal(rest);
      if (!rx) return std::unexpected(fmt::format("transcript {}: cannot read '{}'", block.letter, line));
      std::string_view after = trim(rx->second);
      if (after.starts_with("\u2026 101 lines \u2026")) {
        // The abbreviation stands for the data lines of transcript A's report.
        exchange.rx += data_lines(a_d5);
        after = trim(after.substr(std::string_view("\u2026 101 lines \u2026").size()));
      } else {
        exchange.rx += rx->first;
      }
      if (after.starts_with('[')) {
        if (const auto ms = time_in(after); ms && !delay_given && exchange.rx.size() == rx->first.size()) {
          exchange.delay_ms = *ms;
          delay_given = true;
        }
      } else {
        add_note(exchange.note, after);
      }
    } else if (line.starts_with('[')) {
      const auto close = line.rfind(']');
      const std::string_view note =
          line.substr(1, close == std::string_view::npos ? std::string_view::npos : close - 1);
      const bool indented = raw.starts_with(' ');
      if (indented && !exchanges.empty()) {
        // About the exchange above: its timing, or how its reply goes.
        Exchange& exchange = exchanges.back();
        if (const auto ms = time_in(note); ms && exchange.rx.empty() && !delay_given) {
          exchange.delay_ms = *ms;
          delay_given = true;
        }
        add_note(exchange.note, note);
      } else if (exchanges.empty()) {
        add_note(recording.header.description, note);
      } else {
        add_note(pending_note, note);  // about what follows
      }
    }
  }
  finish();
  return recording;
}

}  // namespace

std::expected<std::map<char, Recording>, std::string> transcripts_from_reference(std::string_view markdown,
                                                                                 std::string_view source) {
  const auto blocks = blocks_of(markdown);
  std::map<char, Recording> out;
  // Transcript A goes first: the others abbreviate its spectral reply.
  std::string a_d5;
  for (const char letter : {'A', 'B', 'C', 'D'}) {
    const auto block = std::ranges::find(blocks, letter, &Block::letter);
    if (block == blocks.end()) return std::unexpected(fmt::format("{}: no transcript {}", source, letter));
    auto recording = read_block(*block, source, a_d5);
    if (!recording) return std::unexpected(recording.error());
    if (letter == 'A') {
      for (const auto& e : recording->exchanges)
        if (e.tx == "d5\n") a_d5 = e.rx;
      if (a_d5.empty()) return std::unexpected("transcript A has no D5 reply");
    }
    const std::string_view title = block->title;
    if (title.find("H1") != std::string_view::npos) recording->header.header_variant = "H1";
    if (title.find("H2") != std::string_view::npos) recording->header.header_variant = "H2";
    out.emplace(letter, std::move(*recording));
  }
  return out;
}

}  // namespace skinspec::simulator::tools
