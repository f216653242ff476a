#pragma once
// Test helper: a reader of udev rule files and an evaluator of the part of udev's rule language
// the project's rule uses, so that the rule can be checked without udev (Debian 12's udevadm
// has no `verify`, and `udevadm test` needs the device present). The syntax follows udev(7):
// comma-separated KEY[{name}] OP "value" pairs, one rule per line; values are shell patterns
// with `|` between alternatives.

#include <expected>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::testing {

struct UdevKey {
  std::string key;        // SUBSYSTEM, ATTRS, ENV, GROUP, ...
  std::string attribute;  // what is in braces: ENV{DEVTYPE} → "DEVTYPE"; empty otherwise
  std::string op;         // ==, !=, =, +=, -=, :=
  std::string value;      // without the quotes
  bool is_match() const { return op == "==" || op == "!="; }
};

struct UdevRule {
  int line = 0;
  std::vector<UdevKey> keys;
};

// Every rule of the text, or "line N: what is wrong" for the first line udev would refuse or
// warn about: an unknown key, an operator the key does not take, a missing or unexpected
// {name}, an unquoted or unterminated value, a missing comma.
std::expected<std::vector<UdevRule>, std::string> parse_udev_rules(const std::string& text);

// A device as udev sees it during an event: its own properties and the chain of its parents
// (nearest first), which ATTRS, SUBSYSTEMS, KERNELS and DRIVERS search.
struct UdevDevice {
  std::string kernel, subsystem, driver;
  std::map<std::string, std::string> env, attributes;
};

struct UdevEvent {
  std::string action = "add";
  UdevDevice device;
  std::vector<UdevDevice> parents;
};

// What the rules assign to the event's device.
struct UdevOutcome {
  std::optional<std::string> owner, group, mode;
  std::map<std::string, std::string> env;  // the device's properties after the rules ran
  std::vector<std::string> symlinks, tags;
};

// Runs the rules in order, as udev does for one rule file. Keys this evaluator does not model
// (GOTO, LABEL, IMPORT, PROGRAM, RUN, ...) are an error rather than silently passed over.
std::expected<UdevOutcome, std::string> apply_udev_rules(const std::vector<UdevRule>& rules, const UdevEvent& event);

}  // namespace skinspec::testing
