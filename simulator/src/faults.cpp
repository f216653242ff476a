#include "skinspec/simulator/faults.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>

namespace skinspec::simulator {

namespace {

using drivers::pr650::HeaderVariant;

struct FaultName {
  FaultKind kind;
  std::string_view name;
};

constexpr std::array<FaultName, 17> kFaultNames{{
    {FaultKind::no_answer, "no-answer"},
    {FaultKind::late, "late"},
    {FaultKind::truncate, "truncate"},
    {FaultKind::garbage, "garbage"},
    {FaultKind::bitflip, "bitflip"},
    {FaultKind::drop_line, "drop-line"},
    {FaultKind::line_count, "line-count"},
    {FaultKind::disconnect, "disconnect"},
    {FaultKind::quality, "quality"},
    {FaultKind::stale, "stale"},
    {FaultKind::reboot, "reboot"},
    {FaultKind::exponent, "exponent"},
    {FaultKind::header, "header"},
    {FaultKind::fast_loss, "fast-loss"},
    {FaultKind::glue, "glue"},
    {FaultKind::error, "error"},
    {FaultKind::busy, "busy"},
}};

std::string known_names() {
  std::string out;
  for (const auto& entry : kFaultNames) {
    if (!out.empty()) out += ", ";
    out += entry.name;
  }
  return out;
}

std::string lower(std::string_view text) {
  std::string out(text);
  std::ranges::transform(out, out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  return text;
}

std::optional<double> to_number(std::string_view text) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<int> to_int(std::string_view text) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

// Which values a fault takes: none, an integer or a number in a range, or one word.
std::expected<void, std::string> read_value(Fault& fault, std::string_view name,
                                            std::optional<std::string_view> value) {
  const auto integer_in = [&](int low, int high, bool required) -> std::expected<void, std::string> {
    if (!value) {
      if (required) return std::unexpected(fmt::format("'{}' needs a value (an integer {}-{})", name, low, high));
      return {};
    }
    const auto n = to_int(*value);
    if (!n || *n < low || *n > high)
      return std::unexpected(fmt::format("the value '{}' of '{}' is not an integer {}-{}", *value, name, low, high));
    fault.amount = *n;
    return {};
  };
  switch (fault.kind) {
    case FaultKind::no_answer:
    case FaultKind::reboot:
    case FaultKind::glue:
      if (value) return std::unexpected(fmt::format("'{}' takes no value", name));
      return {};
    case FaultKind::late: {
      if (!value) return {};
      const auto ms = to_number(*value);
      if (!ms || *ms < 0 || *ms > 600000)
        return std::unexpected(fmt::format("the value '{}' of 'late' is not a delay of 0-600000 ms", *value));
      fault.amount = *ms;
      return {};
    }
    case FaultKind::truncate:
    case FaultKind::disconnect:
      return integer_in(0, 1000000, false);
    case FaultKind::garbage:
    case FaultKind::bitflip:
      return integer_in(1, 100000, false);
    case FaultKind::drop_line:
      return integer_in(1, 100000, false);
    case FaultKind::line_count:
      return integer_in(0, 10000, true);
    case FaultKind::quality:
      return integer_in(0, 99, true);
    case FaultKind::stale:
      return integer_in(0, 99, false);
    case FaultKind::fast_loss:
      return integer_in(1, 10000, true);
    case FaultKind::error:
      return integer_in(-99999, -1, true);
    case FaultKind::busy:
      return integer_in(1, 10000, false);
    case FaultKind::exponent:
      if (!value) return {};
      if (*value != "e" && *value != "E")
        return std::unexpected(fmt::format("the value '{}' of 'exponent' is neither 'e' nor 'E'", *value));
      fault.exponent = value->front();
      return {};
    case FaultKind::header: {
      if (!value) return {};
      const std::string v = lower(*value);
      if (v == "h1") {
        fault.header = HeaderVariant::h1_bare_cr;
      } else if (v == "h2") {
        fault.header = HeaderVariant::h2_two_lines;
      } else {
        return std::unexpected(fmt::format("the value '{}' of 'header' is neither 'h1' nor 'h2'", *value));
      }
      return {};
    }
  }
  return {};
}

Fault make_fault(FaultKind kind, double amount = -1) {
  Fault fault;
  fault.kind = kind;
  fault.amount = amount;
  return fault;
}

constexpr std::array<std::string_view, 9> kWordCommands{"photo", "q", "se", "ss", "sk", "sn", "sh", "sf", "su"};

// "*", a command letter, a letter with its numeric code (only B, M and D have one), or one of
// the newer meters' keywords and two-letter setups.
bool valid_command(std::string_view command) {
  if (command == "*" || std::ranges::find(kWordCommands, command) != kWordCommands.end()) return true;
  if (command.empty() || std::string_view("bsfmdeitpav").find(command.front()) == std::string_view::npos) return false;
  const std::string_view code = command.substr(1);
  if (code.empty()) return true;
  if (std::string_view("bmd").find(command.front()) == std::string_view::npos) return false;
  return code.size() <= 4 && std::ranges::all_of(code, [](unsigned char c) { return std::isdigit(c) != 0; });
}

}  // namespace

std::string_view to_string(FaultKind kind) {
  for (const auto& entry : kFaultNames)
    if (entry.kind == kind) return entry.name;
  return "unknown";
}

std::string Fault::to_string() const {
  const std::string_view name = simulator::to_string(kind);
  switch (kind) {
    case FaultKind::exponent:
      return fmt::format("{}={}", name, exponent);
    case FaultKind::header:
      return fmt::format("{}={}", name, header == HeaderVariant::h1_bare_cr ? "h1" : "h2");
    default:
      break;
  }
  if (amount < 0 && kind != FaultKind::error) return std::string(name);  // error's value is negative
  return fmt::format("{}={}", name, amount);
}

std::expected<Fault, std::string> parse_fault(std::string_view text) {
  text = trim(text);
  const auto equals = text.find('=');
  std::string name = lower(trim(text.substr(0, equals)));
  std::ranges::replace(name, '_', '-');
  std::optional<std::string_view> value;
  if (equals != std::string_view::npos) value = trim(text.substr(equals + 1));
  if (value && value->empty()) return std::unexpected(fmt::format("'{}=' lacks its value", name));
  const auto entry = std::ranges::find(kFaultNames, name, &FaultName::name);
  if (entry == kFaultNames.end()) {
    if (name.empty()) return std::unexpected(fmt::format("no fault named (known: {})", known_names()));
    return std::unexpected(fmt::format("unknown fault '{}' (known: {})", name, known_names()));
  }
  Fault fault;
  fault.kind = entry->kind;
  if (auto read = read_value(fault, entry->name, value); !read) return std::unexpected(read.error());
  return fault;
}

bool FaultSpec::matches(std::string_view key) const {
  if (command == "*") return true;
  // A keyword is named in full: "p" (the poll) does not name PHOTO.
  if (key == "photo") return command == key;
  if (command.size() == 1) return !key.empty() && key.front() == command.front();
  return key == command;
}

std::string FaultSpec::to_string() const {
  std::string out = fmt::format("{}:{}", command, fault.to_string());
  if (at > 0) out += fmt::format("@{}{}", at, onwards ? "+" : "");
  return out;
}

std::expected<FaultSpec, std::string> parse_fault_spec(std::string_view text) {
  const std::string_view spec = trim(text);
  const auto fail = [&](const std::string& why) { return std::unexpected(fmt::format("fault '{}': {}", spec, why)); };
  const auto colon = spec.find(':');
  if (colon == std::string_view::npos)
    return fail("expected COMMAND:FAULT[=VALUE][@N], for example d5:truncate or m0:no-answer@2");
  FaultSpec result;
  result.command = lower(trim(spec.substr(0, colon)));
  if (!valid_command(result.command))
    return fail(
        fmt::format("'{}' is not a meter command: use *, a letter (b s f m d e i t p a v), a letter with its "
                    "code (m0, d5, d110), a setup (se ss sk sn sh sf su), photo or q",
                    result.command));
  std::string_view rest = spec.substr(colon + 1);
  if (const auto at = rest.rfind('@'); at != std::string_view::npos) {
    std::string_view occurrence = trim(rest.substr(at + 1));
    rest = rest.substr(0, at);
    if (occurrence.ends_with('+')) {
      result.onwards = true;
      occurrence.remove_suffix(1);
    }
    const auto n = to_int(occurrence);
    if (!n || *n < 1) return fail(fmt::format("'@{}' is not a count of 1 or more (@N or @N+)", occurrence));
    result.at = *n;
  }
  auto fault = parse_fault(rest);
  if (!fault) return fail(fault.error());
  result.fault = *fault;
  return result;
}

FaultPlan::FaultPlan(std::vector<FaultSpec> specs, double random_rate, std::uint64_t seed, int gap)
    : specs_(std::move(specs)), seen_(specs_.size(), 0), random_rate_(random_rate), gap_(gap), rng_(seed) {}

std::expected<FaultPlan, std::string> FaultPlan::parse(std::span<const std::string> texts, double random_rate,
                                                       std::uint64_t seed, int gap) {
  if (!(random_rate >= 0 && random_rate <= 1))
    return std::unexpected(fmt::format("fault rate {} is not a probability between 0 and 1", random_rate));
  if (gap < 0) return std::unexpected(fmt::format("fault gap {} is negative", gap));
  std::vector<FaultSpec> specs;
  for (const auto& text : texts) {
    auto spec = parse_fault_spec(text);
    if (!spec) return std::unexpected(spec.error());
    specs.push_back(*spec);
  }
  return FaultPlan(std::move(specs), random_rate, seed, gap);
}

std::vector<Fault> FaultPlan::next(std::string_view key) {
  std::vector<Fault> faults;
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const FaultSpec& spec = specs_[i];
    if (!spec.matches(key)) continue;
    const int n = ++seen_[i];
    if (spec.at == 0 || n == spec.at || (spec.onwards && n > spec.at)) faults.push_back(spec.fault);
  }
  if (random_rate_ <= 0) return faults;
  if (spared_ > 0) {
    --spared_;
  } else if (std::uniform_real_distribution<double>(0, 1)(rng_) < random_rate_) {
    spared_ = gap_;
    // Line noise for any command; for a measurement also the codes a real meter gives.
    std::vector<Fault> choices;
    for (const FaultKind kind : {FaultKind::no_answer, FaultKind::late, FaultKind::truncate, FaultKind::garbage,
                                 FaultKind::bitflip, FaultKind::drop_line})
      choices.push_back(make_fault(kind));
    if (!key.empty() && key.front() == 'm')
      for (const int code : {7, 8, 10, 18, 19}) choices.push_back(make_fault(FaultKind::quality, code));
    faults.push_back(choices[std::uniform_int_distribution<std::size_t>(0, choices.size() - 1)(rng_)]);
  }
  return faults;
}

}  // namespace skinspec::simulator
