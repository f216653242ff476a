#pragma once
// What the `skinspec session` subcommands share: the server options and the client they make.

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "api_client.hpp"

namespace skinspec::cli {

struct ServerArgs {
  std::string server = "http://127.0.0.1:8650";
  std::string token_file;
  std::string ca_file;  // for https://
  bool json = false;

  ApiClient client() const { return ApiClient(parse_server_url(server), resolve_token(token_file), ca_file); }
};

// Registers --server, --token-file, --ca-file and --json on `command`.
void add_server_options(CLI::App& command, ServerArgs& args);

// skinspec session measure: queues a measurement and follows it to its result.
void add_session_measure_command(CLI::App& session, const std::shared_ptr<ServerArgs>& server);

}  // namespace skinspec::cli
