// skinspec token new|revoke|list: the named tokens of skinspecd's token file, which holds only
// their hashes (docs/security.md). A new token's secret is printed once and kept nowhere, so
// a stolen file lets nobody in; skinspecd reads the file again on SIGHUP.

#include <sys/stat.h>

#include <cerrno>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common.hpp"
#include "skinspec/api/tokens.hpp"

namespace skinspec::cli {

namespace {

// Where the packaged service is given its token file from (docs/service.md).
constexpr const char* kDefaultTokenFile = "/etc/skinspec/tokens.json";

struct TokenArgs {
  std::string name;
  std::string scope;
  std::string file = kDefaultTokenFile;
};

void note(const std::string& message) {
  std::cout.flush();
  std::cerr << printable_message("skinspec: " + message) << '\n';
}

// The file's tokens; none when it does not exist yet and `missing_is_empty` (the first
// `token new` makes it). An old two-token file is read as its tokens "read" and "operator",
// and written back in the named format, their secrets kept only as hashes.
std::vector<api::NamedToken> current_tokens(const std::string& file, bool missing_is_empty) {
  struct stat st{};
  if (missing_is_empty && ::stat(file.c_str(), &st) != 0 && errno == ENOENT) return {};
  auto read = api::read_token_file(file);
  if (!read) throw Failure{kBadInput, read.error()};
  if (read->format == api::TokenFileFormat::legacy)
    note(file + ": an old two-token file; written back with named tokens, its read_token as 'read' (scope read) " +
         "and its operator_token as 'operator' (scope admin), which keep working");
  return std::move(read->tokens);
}

void write(const std::string& file, const std::vector<api::NamedToken>& tokens) {
  if (auto written = api::write_token_file(file, tokens); !written) throw Failure{kBadInput, written.error()};
}

void run_new(const TokenArgs& args) {
  auto tokens = current_tokens(args.file, true);
  for (const auto& t : tokens)
    if (t.name == args.name)
      throw Failure{kBadInput, args.file + ": a token named '" + args.name + "' exists already (revoke it first)"};
  const auto scope = api::parse_scope(args.scope);  // CLI11 checked it
  if (!scope) throw Failure{kBadInput, "--scope must be " + api::scope_names()};
  const std::string secret = api::new_token_secret();
  tokens.push_back({args.name, *scope, api::hash_token(secret)});
  write(args.file, tokens);
  std::cout << secret << '\n';
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
  note(
      fmt::format("token '{}' (scope {}) added to {}; its secret, above, is shown only this once. "
                  "skinspecd takes it on SIGHUP.",
                  args.name, args.scope, args.file));
}

void run_revoke(const TokenArgs& args) {
  auto tokens = current_tokens(args.file, false);
  const auto erased = std::erase_if(tokens, [&](const api::NamedToken& t) { return t.name == args.name; });
  if (erased == 0) throw Failure{kBadInput, args.file + ": no token named '" + args.name + "'"};
  write(args.file, tokens);
  note(fmt::format("token '{}' revoked in {}; skinspecd refuses it once it has had SIGHUP.", args.name, args.file));
}

void run_list(const TokenArgs& args) {
  const auto tokens = current_tokens(args.file, false);
  std::cout << fmt::format("{:<24} {}\n", "NAME", "SCOPE");
  for (const auto& t : tokens) std::cout << fmt::format("{:<24} {}\n", t.name, api::to_string(t.scope));
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
}

CLI::Option* add_file_option(CLI::App& command, TokenArgs& args) {
  return command.add_option("--file", args.file, "skinspecd's token file (--token-file), mode 0600")
      ->capture_default_str();
}

CLI::Option* add_name(CLI::App& command, TokenArgs& args, const std::string& what) {
  return command.add_option("NAME", args.name, what)
      ->required()
      ->check(CLI::Validator(
          [](const std::string& name) {
            return api::valid_token_name(name) ? std::string() : "1 to 64 letters, digits, '.', '_' or '-'";
          },
          "NAME"));
}

}  // namespace

void add_token_command(CLI::App& app) {
  auto* token = app.add_subcommand("token", "the named tokens of skinspecd's token file: new, revoke, list");
  token->require_subcommand(1);

  auto args_new = std::make_shared<TokenArgs>();
  auto* made = token->add_subcommand("new", "add a token; print its secret, once");
  add_name(*made, *args_new, "the token's name: the person or program it is for");
  std::vector<std::string> scopes;
  for (const api::Scope scope : api::kScopes) scopes.emplace_back(api::to_string(scope));
  made->add_option("--scope", args_new->scope, "what it may do: read (GET), measure (and jobs), admin (everything)")
      ->required()
      ->check(CLI::IsMember(scopes));
  add_file_option(*made, *args_new);
  made->callback([args_new] { run_new(*args_new); });

  auto args_revoke = std::make_shared<TokenArgs>();
  auto* revoke = token->add_subcommand("revoke", "remove a token from the file");
  add_name(*revoke, *args_revoke, "the token's name");
  add_file_option(*revoke, *args_revoke);
  revoke->callback([args_revoke] { run_revoke(*args_revoke); });

  auto args_list = std::make_shared<TokenArgs>();
  auto* list = token->add_subcommand("list", "the tokens' names and scopes (never their secrets)");
  add_file_option(*list, *args_list);
  list->callback([args_list] { run_list(*args_list); });
}

}  // namespace skinspec::cli
