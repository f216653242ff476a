// docs/cli.md against the built skinspec: every command and option that `skinspec --help` and
// each command's `--help` print is documented there, and docs/cli.md documents nothing else.
//
// The program's side is read from CLI11's help: its "Subcommands:" (names and aliases),
// "Positionals:" and "Options:" sections, whose entries start two spaces in and whose
// descriptions, when they do not fit, go on lines further in. The documents' side is read from
// docs/cli.md: a heading `## skinspec COMMAND...` per command, a line `Alias: `NAME`` per alias,
// and table rows whose first cell holds the option in code: its names (`-o, --output`), then its
// value, the choices of which are written `a|b` (in a table, `a\|b`); a positional argument is
// its name alone. `-h, --help`, which every command takes, is documented once, under
// `## skinspec`.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/testkit/process.hpp"

namespace skinspec {
namespace {

// One option or positional argument as the help or the documents give it.
struct OptionEntry {
  std::vector<std::string> names;  // "-o", "--output"; or the positional's name, "FILE"
  bool positional = false;
  bool takes_value = false;       // for options: a value follows the names
  std::set<std::string> choices;  // the values it accepts, where it names them
};

// One command: its path under skinspec ("session new"; "" for skinspec itself).
struct CommandEntry {
  std::set<std::string> aliases;
  std::vector<OptionEntry> options;
};

using Commands = std::map<std::string, CommandEntry>;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

std::vector<std::string> split(std::string_view text, std::string_view separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t at; (at = text.find(separator, start)) != std::string_view::npos; start = at + separator.size())
    parts.emplace_back(text.substr(start, at - start));
  parts.emplace_back(text.substr(start));
  return parts;
}

std::vector<std::string> words(std::string_view text) {
  std::vector<std::string> found;
  for (const auto& part : split(text, " "))
    if (!part.empty()) found.push_back(part);
  return found;
}

std::string joined(const std::set<std::string>& names) {
  std::string text;
  for (const auto& name : names) text += (text.empty() ? "" : ", ") + name;
  return text.empty() ? "none" : text;
}

std::string command_name(const std::string& path) { return path.empty() ? "skinspec" : "skinspec " + path; }

// --- The program's help --------------------------------------------------------------------

// What one `--help` says: the commands under this one (each with its aliases), and its options.
struct Help {
  std::vector<std::vector<std::string>> subcommands;  // name first, then aliases
  std::vector<OptionEntry> options;
};

// An entry's left column: what stands before the description (two or more blanks), or the whole
// entry when the description went on the next line.
std::string left_column(std::string_view entry) {
  const auto gap = entry.find("  ");
  return std::string(entry.substr(0, gap));
}

// "TEXT:{paper,extended}=extended" → {"paper", "extended"}; nothing without braces.
std::set<std::string> choices_in(std::string_view type) {
  const auto open = type.find(":{");
  if (open == std::string_view::npos) return {};
  const auto close = type.find('}', open);
  if (close == std::string_view::npos) return {};
  const auto values = split(type.substr(open + 2, close - open - 2), ",");
  return {values.begin(), values.end()};
}

Help parse_help(const std::string& text) {
  enum class Section { other, subcommands, positionals, options };
  Help help;
  Section section = Section::other;
  for (const auto& line : lines_of(text)) {
    if (line.empty()) continue;
    if (line.front() != ' ') {
      section = line == "Subcommands:"   ? Section::subcommands
                : line == "Positionals:" ? Section::positionals
                : line == "Options:"     ? Section::options
                                         : Section::other;
      continue;
    }
    // Entries start two blanks in; a description that did not fit beside its entry is further in.
    if (section == Section::other || !line.starts_with("  ") || line.size() < 3 || line[2] == ' ') continue;
    const std::string left = left_column(std::string_view(line).substr(2));
    if (section == Section::subcommands) {
      help.subcommands.push_back(split(left, ", "));
      continue;
    }
    const auto tokens = words(left);
    OptionEntry option;
    option.positional = section == Section::positionals;
    if (option.positional) {
      option.names = {tokens.front()};
    } else {
      option.names = split(tokens.front(), ",");
      option.takes_value = tokens.size() > 1 && tokens[1] != "Excludes:" && tokens[1] != "Needs:";
      if (option.takes_value) option.choices = choices_in(tokens[1]);
    }
    help.options.push_back(std::move(option));
  }
  return help;
}

testing::ProcessResult run_skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

// Every command of the built program, from `skinspec --help` down through each command's.
void read_program(const std::string& path, Commands& commands, std::vector<std::string>& failures) {
  std::vector<std::string> args = path.empty() ? std::vector<std::string>{} : words(path);
  args.push_back("--help");
  const auto result = run_skinspec(args);
  if (!result.exited() || result.exit_status != 0) {
    failures.push_back(command_name(path) + " --help: " + result.describe());
    return;
  }
  const Help help = parse_help(result.out);
  commands[path].options = help.options;
  for (const auto& names : help.subcommands) {
    const std::string sub = path.empty() ? names.front() : path + " " + names.front();
    commands[sub].aliases = {names.begin() + 1, names.end()};
    read_program(sub, commands, failures);
  }
}

// --- docs/cli.md ---------------------------------------------------------------------------

// The code in a row's first cell, `\|` read as `|`; nothing when the cell holds no code.
std::optional<std::string> first_cell_code(std::string_view row) {
  if (!row.starts_with("|")) return std::nullopt;
  const auto cell_start = row.find_first_not_of(' ', 1);
  if (cell_start == std::string_view::npos || row[cell_start] != '`') return std::nullopt;
  const auto close = row.find('`', cell_start + 1);
  if (close == std::string_view::npos) return std::nullopt;
  std::string code(row.substr(cell_start + 1, close - cell_start - 1));
  for (std::size_t at; (at = code.find("\\|")) != std::string::npos;) code.replace(at, 2, "|");
  return code;
}

OptionEntry option_from_cell(const std::string& code) {
  const auto tokens = words(code);
  OptionEntry option;
  if (tokens.empty()) return option;
  if (!tokens.front().starts_with("-")) {
    // A positional argument: its name, perhaps with "..." for several.
    std::string name = tokens.front();
    if (name.ends_with("...")) name.resize(name.size() - 3);
    option.names = {name};
    option.positional = true;
    return option;
  }
  std::size_t i = 0;
  for (; i < tokens.size() && tokens[i].starts_with("-"); ++i) {
    std::string name = tokens[i];
    if (name.ends_with(",")) name.pop_back();
    option.names.push_back(name);
  }
  if (i < tokens.size()) {
    option.takes_value = true;
    if (tokens[i].find('|') != std::string::npos) {
      const auto values = split(tokens[i], "|");
      option.choices = {values.begin(), values.end()};
    }
  }
  return option;
}

// The commands docs/cli.md documents: a `## skinspec ...` heading each, up to the next heading
// of that level or above.
Commands parse_docs(const std::string& text) {
  Commands commands;
  std::optional<std::string> current;
  for (const auto& line : lines_of(text)) {
    if (line.starts_with("# ") || line.starts_with("## ")) {
      current.reset();
      const std::string heading = line.substr(line.find(' ') + 1);
      if (heading == "skinspec") current = "";
      else if (heading.starts_with("skinspec ")) current = heading.substr(9);
      if (current) commands[*current];
      continue;
    }
    if (!current) continue;
    if (line.starts_with("Alias: ") || line.starts_with("Aliases: ")) {
      for (std::size_t open = line.find('`'); open != std::string::npos; open = line.find('`', open)) {
        const auto close = line.find('`', open + 1);
        if (close == std::string::npos) break;
        commands[*current].aliases.insert(line.substr(open + 1, close - open - 1));
        open = close + 1;
      }
      continue;
    }
    if (const auto code = first_cell_code(line)) commands[*current].options.push_back(option_from_cell(*code));
  }
  return commands;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// --- The comparison --------------------------------------------------------------------------

// Every name a command's options have, `-h` and `--help` left out below skinspec itself.
std::set<std::string> names_of(const std::string& path, const CommandEntry& command) {
  std::set<std::string> names;
  for (const auto& option : command.options)
    for (const auto& name : option.names)
      if (path.empty() || (name != "-h" && name != "--help")) names.insert(name);
  return names;
}

const OptionEntry* find_option(const CommandEntry& command, const std::string& name) {
  for (const auto& option : command.options)
    if (std::ranges::find(option.names, name) != option.names.end()) return &option;
  return nullptr;
}

std::set<std::string> difference(const std::set<std::string>& a, const std::set<std::string>& b) {
  std::set<std::string> only_a;
  std::ranges::set_difference(a, b, std::inserter(only_a, only_a.end()));
  return only_a;
}

// What differs between the program and docs/cli.md, one line each; nothing when they agree.
std::vector<std::string> compare(const Commands& program, const Commands& docs) {
  std::vector<std::string> problems;
  std::set<std::string> program_paths, docs_paths;
  for (const auto& [path, command] : program) program_paths.insert(path);
  for (const auto& [path, command] : docs) docs_paths.insert(path);
  for (const auto& path : difference(program_paths, docs_paths))
    problems.push_back(command_name(path) + ": a command of the program without its `## " + command_name(path) +
                       "` section in docs/cli.md");
  for (const auto& path : difference(docs_paths, program_paths))
    problems.push_back(command_name(path) + ": documented in docs/cli.md, but the program has no such command");

  for (const auto& [path, command] : program) {
    const auto documented = docs.find(path);
    if (documented == docs.end()) continue;
    const std::string where = command_name(path);
    if (command.aliases != documented->second.aliases)
      problems.push_back(where + ": aliases " + joined(command.aliases) + " in the program, " +
                         joined(documented->second.aliases) + " in docs/cli.md (a line `Alias: `NAME``)");
    const auto in_program = names_of(path, command);
    const auto in_docs = names_of(path, documented->second);
    for (const auto& name : difference(in_program, in_docs))
      problems.push_back(where + ": " + name + " is missing from docs/cli.md");
    for (const auto& name : difference(in_docs, in_program))
      problems.push_back(where + ": " + name + " is in docs/cli.md, but the program has no such option");

    std::multiset<std::string> rows;
    for (const auto& option : documented->second.options)
      for (const auto& name : option.names) rows.insert(name);
    for (const auto& name : in_docs)
      if (rows.count(name) > 1) problems.push_back(where + ": " + name + " is listed more than once in docs/cli.md");

    for (const auto& option : command.options) {
      const std::string& name = option.names.front();
      if (!in_docs.contains(name)) continue;
      const OptionEntry& doc = *find_option(documented->second, name);
      const std::set<std::string> names(option.names.begin(), option.names.end());
      const std::set<std::string> doc_names(doc.names.begin(), doc.names.end());
      if (names != doc_names)
        problems.push_back(where + ": " + name + " is named " + joined(names) + " by the program and " +
                           joined(doc_names) + " in one row of docs/cli.md");
      if (option.positional) continue;
      if (option.takes_value != doc.takes_value)
        problems.push_back(where + ": " + name + (option.takes_value ? " takes a value" : " is a flag") +
                           ", but docs/cli.md writes it " + (doc.takes_value ? "with a value" : "without one"));
      else if (!option.choices.empty() && option.choices != doc.choices)
        problems.push_back(where + ": " + name + " accepts " + joined(option.choices) + ", docs/cli.md says " +
                           joined(doc.choices) + " (write them `a|b` after the option)");
    }
  }
  return problems;
}

std::string listed(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += "\n  " + line;
  return text;
}

// --- The tests -------------------------------------------------------------------------------

// The program's commands and the document's, read once for the suite (each --help is a process).
class CliDocs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    read_program("", program_, failures_);
    docs_ = parse_docs(read_file(SKINSPEC_CLI_DOCS_FILE));
  }

  inline static Commands program_;
  inline static Commands docs_;
  inline static std::vector<std::string> failures_;
};

TEST_F(CliDocs, EveryHelpOfTheProgramIsRead) {
  EXPECT_THAT(failures_, ::testing::IsEmpty()) << listed(failures_);
  // Not an empty comparison: the program's commands and a few known options were found.
  ASSERT_TRUE(program_.contains("fit")) << "no `fit` in skinspec --help";
  ASSERT_TRUE(program_.contains("session new")) << "no `session new` in skinspec session --help";
  EXPECT_TRUE(find_option(program_.at("fit"), "FILE"));
  EXPECT_TRUE(find_option(program_.at("fit"), "--model"));
  EXPECT_TRUE(find_option(program_.at(""), "--version"));
  EXPECT_GE(program_.size(), 15u);
}

TEST_F(CliDocs, TheDocumentHasASectionForEachCommand) {
  ASSERT_FALSE(docs_.empty()) << "no `## skinspec ...` section in " << SKINSPEC_CLI_DOCS_FILE;
  EXPECT_TRUE(docs_.contains(""));
  EXPECT_TRUE(docs_.contains("fit"));
}

TEST_F(CliDocs, TheDocumentListsExactlyTheProgramsCommandsAndOptions) {
  const auto problems = compare(program_, docs_);
  EXPECT_THAT(problems, ::testing::IsEmpty())
      << "docs/cli.md and `skinspec --help` differ; update docs/cli.md:" << listed(problems);
}

// The readers themselves, on text of the shapes CLI11 and docs/cli.md write, so that a reader
// that finds nothing cannot pass for agreement.
TEST(CliDocsReaders, HelpIsReadAsCli11WritesIt) {
  const Help help = parse_help(
      "fit a skin model\n"
      "Usage: skinspec fit [OPTIONS] FILE\n\n"
      "Positionals:\n"
      "  FILE TEXT REQUIRED          CSV of spectra\n\n"
      "Options:\n"
      "  -h,--help                   Print this help message and exit\n"
      "  --model TEXT:{paper,extended}=extended\n"
      "                              skin model\n"
      "  --session INT:POSITIVE Excludes: --new-session\n"
      "                              an open session\n"
      "  --json                      print JSON\n"
      "  -o,--output TEXT REQUIRED   the PNG\n\n"
      "Subcommands:\n"
      "  colour, color               print colour\n");
  ASSERT_EQ(help.options.size(), 6u);
  EXPECT_TRUE(help.options[0].positional);
  EXPECT_EQ(help.options[0].names, std::vector<std::string>{"FILE"});
  EXPECT_EQ(help.options[1].names, (std::vector<std::string>{"-h", "--help"}));
  EXPECT_EQ(help.options[2].choices, (std::set<std::string>{"paper", "extended"}));
  EXPECT_TRUE(help.options[3].takes_value);
  EXPECT_FALSE(help.options[4].takes_value);
  EXPECT_EQ(help.options[5].names, (std::vector<std::string>{"-o", "--output"}));
  ASSERT_EQ(help.subcommands.size(), 1u);
  EXPECT_EQ(help.subcommands[0], (std::vector<std::string>{"colour", "color"}));
}

TEST(CliDocsReaders, TheDocumentIsReadByItsHeadingsAliasesAndFirstCells) {
  const Commands docs = parse_docs(
      "# The `skinspec` command\n\n"
      "| `--not-a-command-option` | outside any command |\n\n"
      "## skinspec colour\n\n"
      "Alias: `color`\n\n"
      "| option | default | what |\n"
      "|---|---|---|\n"
      "| `FILE...` | | the files |\n"
      "| `--illuminant D65\\|A\\|FILE` | `D65` | the light |\n"
      "| `-o, --output OUT.png` | | the PNG |\n"
      "| `--json` | | JSON |\n\n"
      "## Exit statuses\n\n"
      "| `--not-an-option-either` | |\n");
  ASSERT_EQ(docs.size(), 1u);
  const CommandEntry& colour = docs.at("colour");
  EXPECT_EQ(colour.aliases, std::set<std::string>{"color"});
  ASSERT_EQ(colour.options.size(), 4u);
  EXPECT_TRUE(colour.options[0].positional);
  EXPECT_EQ(colour.options[0].names, std::vector<std::string>{"FILE"});
  EXPECT_EQ(colour.options[1].choices, (std::set<std::string>{"D65", "A", "FILE"}));
  EXPECT_EQ(colour.options[2].names, (std::vector<std::string>{"-o", "--output"}));
  EXPECT_TRUE(colour.options[2].takes_value);
  EXPECT_FALSE(colour.options[3].takes_value);
}

TEST(CliDocsReaders, AFlagAddedOrRemovedIsAProblem) {
  Commands program, docs;
  program["fit"].options = {OptionEntry{{"--model"}, false, true, {"paper", "extended"}},
                            OptionEntry{{"--scale"}, false, true, {}}};
  docs["fit"].options = {OptionEntry{{"--model"}, false, true, {"paper", "extended"}},
                         OptionEntry{{"--gone"}, false, false, {}}};
  EXPECT_THAT(compare(program, docs),
              ::testing::UnorderedElementsAre(::testing::HasSubstr("--scale is missing from docs/cli.md"),
                                              ::testing::HasSubstr("--gone is in docs/cli.md, but the program")));
  docs["fit"].options[1] = OptionEntry{{"--scale"}, false, true, {}};
  EXPECT_THAT(compare(program, docs), ::testing::IsEmpty());
  docs["fit"].options[0].choices = {"paper"};
  EXPECT_THAT(compare(program, docs), ::testing::ElementsAre(::testing::HasSubstr("accepts extended, paper")));
}

}  // namespace
}  // namespace skinspec
