#include "support/udev_rules.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <sstream>
#include <string_view>

namespace skinspec::testing {

namespace {

enum class Braces { none, required, optional };

struct KeySyntax {
  std::string_view name;
  Braces braces;
  bool matches, assigns;
};

// udev(7), "Rules files": which keys exist, whether they take {name}, and which operators.
constexpr std::array kKeys{
    KeySyntax{"ACTION", Braces::none, true, false},    KeySyntax{"DEVPATH", Braces::none, true, false},
    KeySyntax{"KERNEL", Braces::none, true, false},    KeySyntax{"KERNELS", Braces::none, true, false},
    KeySyntax{"NAME", Braces::none, true, true},       KeySyntax{"SYMLINK", Braces::none, true, true},
    KeySyntax{"SUBSYSTEM", Braces::none, true, false}, KeySyntax{"SUBSYSTEMS", Braces::none, true, false},
    KeySyntax{"DRIVER", Braces::none, true, false},    KeySyntax{"DRIVERS", Braces::none, true, false},
    KeySyntax{"ATTR", Braces::required, true, true},   KeySyntax{"ATTRS", Braces::required, true, false},
    KeySyntax{"SYSCTL", Braces::required, true, true}, KeySyntax{"ENV", Braces::required, true, true},
    KeySyntax{"CONST", Braces::required, true, false}, KeySyntax{"TAG", Braces::none, true, true},
    KeySyntax{"TAGS", Braces::none, true, false},      KeySyntax{"TEST", Braces::optional, true, false},
    KeySyntax{"PROGRAM", Braces::none, true, false},   KeySyntax{"RESULT", Braces::none, true, false},
    KeySyntax{"OWNER", Braces::none, false, true},     KeySyntax{"GROUP", Braces::none, false, true},
    KeySyntax{"MODE", Braces::none, false, true},      KeySyntax{"SECLABEL", Braces::required, false, true},
    KeySyntax{"RUN", Braces::optional, false, true},   KeySyntax{"LABEL", Braces::none, false, true},
    KeySyntax{"GOTO", Braces::none, false, true},      KeySyntax{"IMPORT", Braces::required, true, true},
    KeySyntax{"OPTIONS", Braces::none, false, true},
};

constexpr std::array<std::string_view, 6> kOperators{"==", "!=", "+=", "-=", ":=", "="};

// One line's pairs, read left to right.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}

  std::expected<std::vector<UdevKey>, std::string> read_all() {
    std::vector<UdevKey> keys;
    while (true) {
      auto key = read_pair();
      if (!key) return std::unexpected(key.error());
      keys.push_back(std::move(*key));
      skip_blanks();
      if (at_end()) return keys;
      if (text_[at_] != ',') return std::unexpected("expected ',' after " + keys.back().key);
      ++at_;
      skip_blanks();
      if (at_end()) return std::unexpected("a ',' ends the line");
    }
  }

 private:
  bool at_end() const { return at_ >= text_.size(); }
  void skip_blanks() {
    while (!at_end() && (text_[at_] == ' ' || text_[at_] == '\t')) ++at_;
  }

  std::expected<UdevKey, std::string> read_pair() {
    UdevKey key;
    const auto start = at_;
    while (!at_end() && (std::isupper(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_')) ++at_;
    key.key = std::string(text_.substr(start, at_ - start));
    if (key.key.empty()) return std::unexpected("expected a key at '" + std::string(text_.substr(start)) + "'");
    if (!at_end() && text_[at_] == '{') {
      const auto close = text_.find('}', at_);
      if (close == std::string_view::npos) return std::unexpected("unterminated '{' after " + key.key);
      key.attribute = std::string(text_.substr(at_ + 1, close - at_ - 1));
      if (key.attribute.empty()) return std::unexpected("empty {} after " + key.key);
      at_ = close + 1;
    }
    skip_blanks();
    const auto op =
        std::ranges::find_if(kOperators, [&](std::string_view o) { return text_.substr(at_).starts_with(o); });
    if (op == kOperators.end()) return std::unexpected("expected an operator after " + key.key);
    key.op = std::string(*op);
    at_ += op->size();
    skip_blanks();
    if (at_end() || text_[at_] != '"') return std::unexpected("the value of " + key.key + " is not quoted");
    const auto close = text_.find('"', at_ + 1);
    if (close == std::string_view::npos) return std::unexpected("unterminated value of " + key.key);
    key.value = std::string(text_.substr(at_ + 1, close - at_ - 1));
    at_ = close + 1;
    return key;
  }

  std::string_view text_;
  std::size_t at_ = 0;
};

std::expected<void, std::string> check_key(const UdevKey& key) {
  const auto syntax = std::ranges::find(kKeys, key.key, &KeySyntax::name);
  if (syntax == kKeys.end()) return std::unexpected("unknown key " + key.key);
  if (syntax->braces == Braces::none && !key.attribute.empty())
    return std::unexpected(key.key + " takes no {" + key.attribute + "}");
  if (syntax->braces == Braces::required && key.attribute.empty()) return std::unexpected(key.key + " needs {name}");
  if (key.is_match() ? !syntax->matches : !syntax->assigns)
    return std::unexpected(key.key + " does not take " + key.op);
  return {};
}

// udev's patterns: shell globs, `|` between alternatives.
bool matches_pattern(const std::string& pattern, const std::string& value) {
  std::istringstream alternatives(pattern);
  std::string alternative;
  if (pattern.empty()) return value.empty();
  while (std::getline(alternatives, alternative, '|'))
    if (fnmatch(alternative.c_str(), value.c_str(), 0) == 0) return true;
  return false;
}

std::optional<std::string> find_value(const std::map<std::string, std::string>& map, const std::string& name) {
  const auto it = map.find(name);
  if (it == map.end()) return std::nullopt;
  return it->second;
}

// A value that is absent matches neither == nor != (udev cannot compare what it cannot read),
// except for ENV, where absent is empty.
bool compare(const UdevKey& key, const std::optional<std::string>& value) {
  if (!value) return false;
  return matches_pattern(key.value, *value) == (key.op == "==");
}

bool is_parent_key(const std::string& key) {
  return key == "KERNELS" || key == "SUBSYSTEMS" || key == "DRIVERS" || key == "ATTRS";
}

std::optional<std::string> property_of(const UdevDevice& device, const UdevKey& key) {
  if (key.key == "KERNEL" || key.key == "KERNELS") return device.kernel;
  if (key.key == "SUBSYSTEM" || key.key == "SUBSYSTEMS") return device.subsystem;
  if (key.key == "DRIVER" || key.key == "DRIVERS") return device.driver;
  return find_value(device.attributes, key.attribute);  // ATTR, ATTRS
}

std::expected<bool, std::string> device_keys_match(const UdevRule& rule, const UdevEvent& event,
                                                   const std::map<std::string, std::string>& env) {
  for (const auto& key : rule.keys) {
    if (!key.is_match() || is_parent_key(key.key)) continue;
    std::optional<std::string> value;
    if (key.key == "ACTION") value = event.action;
    else if (key.key == "ENV") value = find_value(env, key.attribute).value_or("");
    else if (key.key == "KERNEL" || key.key == "SUBSYSTEM" || key.key == "DRIVER" || key.key == "ATTR")
      value = property_of(event.device, key);
    else return std::unexpected("line " + std::to_string(rule.line) + ": matching on " + key.key + " is not modelled");
    if (!compare(key, value)) return false;
  }
  return true;
}

// udev(7): the keys that search the parents must all match one and the same device.
bool parent_keys_match(const UdevRule& rule, const UdevEvent& event) {
  std::vector<const UdevKey*> keys;
  for (const auto& key : rule.keys)
    if (key.is_match() && is_parent_key(key.key)) keys.push_back(&key);
  if (keys.empty()) return true;
  auto all_match = [&](const UdevDevice& device) {
    return std::ranges::all_of(keys, [&](const UdevKey* key) { return compare(*key, property_of(device, *key)); });
  };
  return all_match(event.device) || std::ranges::any_of(event.parents, all_match);
}

void assign(std::optional<std::string>& field, bool& final, const UdevKey& key) {
  if (final) return;
  field = key.value;
  final = key.op == ":=";
}

void add_to(std::vector<std::string>& list, const UdevKey& key) {
  if (key.op == "=" || key.op == ":=") list.clear();
  if (key.op == "-=") std::erase(list, key.value);
  else list.push_back(key.value);
}

struct Finals {
  bool owner = false, group = false, mode = false;
};

std::expected<void, std::string> apply_assignment(const UdevKey& key, int line, UdevOutcome& outcome, Finals& finals) {
  if (key.value.find_first_of("$%") != std::string::npos)
    return std::unexpected("line " + std::to_string(line) + ": substitutions in " + key.key + " are not modelled");
  if (key.key == "OWNER") assign(outcome.owner, finals.owner, key);
  else if (key.key == "GROUP") assign(outcome.group, finals.group, key);
  else if (key.key == "MODE") assign(outcome.mode, finals.mode, key);
  else if (key.key == "ENV" && key.value.empty()) outcome.env.erase(key.attribute);
  else if (key.key == "ENV") outcome.env[key.attribute] = key.value;
  else if (key.key == "SYMLINK") add_to(outcome.symlinks, key);
  else if (key.key == "TAG") add_to(outcome.tags, key);
  else return std::unexpected("line " + std::to_string(line) + ": assigning " + key.key + " is not modelled");
  return {};
}

}  // namespace

std::expected<std::vector<UdevRule>, std::string> parse_udev_rules(const std::string& text) {
  std::vector<UdevRule> rules;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    if (line.back() == '\\')
      return std::unexpected("line " + std::to_string(number) + ": continued lines are not read");
    auto keys = LineReader(std::string_view(line).substr(first)).read_all();
    if (!keys) return std::unexpected("line " + std::to_string(number) + ": " + keys.error());
    for (const auto& key : *keys)
      if (auto checked = check_key(key); !checked)
        return std::unexpected("line " + std::to_string(number) + ": " + checked.error());
    rules.push_back({number, std::move(*keys)});
  }
  return rules;
}

std::expected<UdevOutcome, std::string> apply_udev_rules(const std::vector<UdevRule>& rules, const UdevEvent& event) {
  UdevOutcome outcome;
  outcome.env = event.device.env;
  Finals finals;
  for (const auto& rule : rules) {
    auto matched = device_keys_match(rule, event, outcome.env);
    if (!matched) return std::unexpected(matched.error());
    if (!*matched || !parent_keys_match(rule, event)) continue;
    for (const auto& key : rule.keys)
      if (!key.is_match())
        if (auto applied = apply_assignment(key, rule.line, outcome, finals); !applied)
          return std::unexpected(applied.error());
  }
  return outcome;
}

}  // namespace skinspec::testing
