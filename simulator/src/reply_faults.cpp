#include "reply_faults.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <vector>

namespace skinspec::simulator::detail {

namespace {

bool is_digit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }

// LF-ended lines (the last one possibly unterminated), each with its line end.
std::vector<std::string> split_lines(std::string_view reply) {
  std::vector<std::string> lines;
  while (!reply.empty()) {
    const auto lf = reply.find('\n');
    const std::size_t n = lf == std::string_view::npos ? reply.size() : lf + 1;
    lines.emplace_back(reply.substr(0, n));
    reply.remove_prefix(n);
  }
  return lines;
}

std::string join(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& line : lines) out += line;
  return out;
}

// "0380.,5.882E-05\r\n": four digits, a point and a comma start every data line.
bool is_data_line(std::string_view line) {
  return line.size() >= 6 && is_digit(line[0]) && is_digit(line[1]) && is_digit(line[2]) && is_digit(line[3]) &&
         line[4] == '.' && line[5] == ',';
}

std::vector<std::size_t> data_line_indices(const std::vector<std::string>& lines) {
  std::vector<std::size_t> indices;
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (is_data_line(lines[i])) indices.push_back(i);
  return indices;
}

std::size_t random_index(std::size_t size, std::mt19937_64& rng) {
  return std::uniform_int_distribution<std::size_t>(0, size - 1)(rng);
}

}  // namespace

bool is_spectral(std::string_view reply) {
  return std::ranges::any_of(split_lines(reply), [](const std::string& line) { return is_data_line(line); });
}

std::string with_quality(std::string reply, int code) {
  if (reply.size() >= 3 && is_digit(reply[0]) && is_digit(reply[1]) && reply[2] == ',') {
    const std::string digits = fmt::format("{:02}", code % 100);
    reply[0] = digits[0];
    reply[1] = digits[1];
  }
  return reply;
}

std::string with_exponent(std::string reply, char letter) {
  for (std::size_t i = 1; i + 2 < reply.size(); ++i) {
    const char c = reply[i];
    if ((c == 'E' || c == 'e') && is_digit(reply[i - 1]) && (reply[i + 1] == '+' || reply[i + 1] == '-') &&
        is_digit(reply[i + 2]))
      reply[i] = letter;
  }
  return reply;
}

std::string with_header(std::string reply, drivers::pr650::HeaderVariant variant) {
  if (!is_spectral(reply)) return reply;
  const auto cr = reply.find('\r');
  if (cr == std::string::npos) return reply;
  const bool two_lines = cr + 1 < reply.size() && reply[cr + 1] == '\n';
  if (variant == drivers::pr650::HeaderVariant::h2_two_lines && !two_lines) reply.insert(cr + 1, "\n");
  if (variant == drivers::pr650::HeaderVariant::h1_bare_cr && two_lines) reply.erase(cr + 1, 1);
  return reply;
}

std::string with_line_count(std::string reply, int count) {
  auto lines = split_lines(reply);
  const auto data = data_line_indices(lines);
  if (data.empty()) return reply;
  const auto wanted = static_cast<std::size_t>(std::max(count, 0));
  if (wanted <= data.size()) {
    for (std::size_t k = data.size(); k-- > wanted;) lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(data[k]));
    return join(lines);
  }
  // More lines than the meter has: continue the grid, repeating the last line's value.
  const std::string& last = lines[data.back()];
  const int last_nm = std::stoi(last.substr(0, 4));
  const std::string tail = last.substr(4);  // ".,5.882E-05\r\n"
  std::vector<std::string> extra;
  for (std::size_t k = data.size(); k < wanted; ++k)
    extra.push_back(fmt::format("{:04}", last_nm + 4 * static_cast<int>(k - data.size() + 1)) + tail);
  lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(data.back()) + 1, extra.begin(), extra.end());
  return join(lines);
}

std::string without_line(std::string reply, int line, std::mt19937_64& rng) {
  auto lines = split_lines(reply);
  if (lines.empty()) return reply;
  std::size_t index = 0;
  if (line > 0) {
    index = std::min(static_cast<std::size_t>(line), lines.size()) - 1;
  } else if (const auto data = data_line_indices(lines); !data.empty()) {
    index = data[random_index(data.size(), rng)];
  } else {
    index = random_index(lines.size(), rng);
  }
  lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(index));
  return join(lines);
}

std::string with_garbage(std::string reply, int count, std::mt19937_64& rng) {
  // Bytes no reply holds: punctuation the meter never prints and the upper half of the byte range.
  static constexpr std::string_view kPunctuation = "#$%&*?@!~^|{}[]";
  std::string noise;
  const int punctuation = static_cast<int>(kPunctuation.size());
  std::uniform_int_distribution<int> pick(0, punctuation + 127);
  for (int i = 0; i < count; ++i) {
    const int k = pick(rng);
    noise += k < punctuation ? kPunctuation[static_cast<std::size_t>(k)] : static_cast<char>(0x80 + k - punctuation);
  }
  // Inside the reply, before its final line end, so that the noise cannot pass for a later reply.
  std::size_t end = reply.size();
  while (end > 0 && (reply[end - 1] == '\r' || reply[end - 1] == '\n')) --end;
  const std::size_t at = end == 0 ? 0 : random_index(end + 1, rng);
  reply.insert(at, noise);
  return reply;
}

std::string with_bitflips(std::string reply, int count, std::mt19937_64& rng) {
  if (reply.empty()) return reply;
  std::uniform_int_distribution<int> bit(0, 7);
  for (int i = 0; i < count; ++i) {
    const std::size_t at = random_index(reply.size(), rng);
    reply[at] = static_cast<char>(static_cast<unsigned char>(reply[at]) ^ (1u << bit(rng)));
  }
  return reply;
}

}  // namespace skinspec::simulator::detail
