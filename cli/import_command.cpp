// skinspec import FILE... (--session ID | --new-session SITE:SUBJECT): other programs' spectra
// files sent to skinspecd, each imported into the session as a job of its own and followed to
// its end. Each file is one transaction: a defect anywhere in it stores nothing of it, and is
// reported by file, line and column (exit 2) after the other files have been tried.

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include "common.hpp"
#include "job_follow.hpp"
#include "model_options.hpp"
#include "session_client.hpp"

namespace skinspec::cli {

namespace {

using nlohmann::json;

struct ImportArgs {
  std::vector<std::string> files;
  long long session = 0;
  std::string new_session;  // SITE:SUBJECT
  ModelKind model = kDefaultModel;
  std::string format;  // empty: recognised by the service from the content
  ScaleRequest scale = ScaleRequest::automatic;
};

// Every file readable before anything is sent, so that a mistyped name does not leave half an
// archive imported.
void check_readable(const std::vector<std::string>& files) {
  for (const auto& path : files) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
      throw Failure{kBadInput, path + ": " + (std::filesystem::exists(path, ec) ? "not a file" : "no such file")};
    if (!std::ifstream(path)) throw Failure{kBadInput, path + ": cannot be read"};
  }
}

long long open_session(const ApiClient& client, const ImportArgs& args) {
  const auto colon = args.new_session.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == args.new_session.size())
    throw Failure{kBadInput, "--new-session " + quote(args.new_session) + ": expected SITE:SUBJECT"};
  const json body = {{"site", args.new_session.substr(0, colon)},
                     {"subject", args.new_session.substr(colon + 1)},
                     {"model", to_string(args.model)}};
  const json session = client.call("POST", "/api/v1/sessions", body);
  std::cerr << fmt::format("session {} opened: site {}, subject {}\n", session["id"].get<long long>(),
                           printable(session["site"].get<std::string>()),
                           printable(session["subject"].get<std::string>()));
  return session["id"].get<long long>();
}

// Imports one file; the job as it ended.
json import_one(const ApiClient& client, long long session, const std::string& path, const ImportArgs& args) {
  std::string target = fmt::format("/api/v1/sessions/{}/imports?name={}", session,
                                   url_encode(std::filesystem::path(path).filename().string()));
  if (!args.format.empty()) target += "&format=" + args.format;
  // auto, the service's default, is left unsaid: a service older than --scale takes the file.
  if (args.scale != ScaleRequest::automatic) target += fmt::format("&scale={}", to_string(args.scale));
  const json accepted = client.post_text(target, read_input(path), "text/plain; charset=utf-8");
  return follow_job(client, accepted.value("id", 0LL));
}

// ", values read as percent (auto)", as the job's result says; nothing for a CGATS file, whose
// SPECTRAL_NORM gives its scale.
std::string how_read(const json& result, ScaleRequest asked) {
  const auto scale = result.contains("scale") && result["scale"].is_string() ? result["scale"].get<std::string>() : "";
  if (scale.empty()) return {};
  return fmt::format(", values read as {}{}", printable(scale), asked == ScaleRequest::automatic ? " (auto)" : "");
}

void run_import(const ServerArgs& server, const ImportArgs& args) {
  check_readable(args.files);
  const auto client = server.client();
  const long long session = args.new_session.empty() ? args.session : open_session(client, args);
  std::vector<std::string> failures;
  bool bad_file = false;
  for (const auto& path : args.files) {
    const json job = import_one(client, session, path, args);
    if (server.json) std::cout << job.dump() << '\n';
    if (job["state"] == "succeeded") {
      if (!server.json)
        std::cout << fmt::format("{}: {} spectra imported into session {} (job {}){}\n", printable(path),
                                 job["result"].value("imported", 0LL), session, job.value("id", 0LL),
                                 how_read(job["result"], args.scale));
      continue;
    }
    bad_file = bad_file || (job["error"].is_object() && job["error"].value("code", "") == "bad_file");
    failures.push_back(fmt::format("{}: job {} {}: {}", path, job.value("id", 0LL), job["state"].get<std::string>(),
                                   job_error_text(job["error"])));
  }
  if (failures.empty()) return;
  std::string message =
      fmt::format("{} of {} files not imported (nothing of them stored)", failures.size(), args.files.size());
  for (const auto& f : failures) message += "\n  " + f;
  throw Failure{bad_file ? kBadInput : kFailure, message};
}

}  // namespace

void add_import_command(CLI::App& app) {
  auto args = std::make_shared<ImportArgs>();
  auto server = std::make_shared<ServerArgs>();
  auto* command = app.add_subcommand(
      "import", "import other programs' spectra files (CSV, CGATS) into a session of skinspecd, each fitted");
  command->add_option("FILE", args->files, "spectra files: CSV by columns or rows, or CGATS (.ti3, .sp, .cgats)")
      ->required();
  auto* session = command->add_option("--session", args->session, "an open session's id")->check(CLI::PositiveNumber);
  auto* fresh = command->add_option("--new-session", args->new_session, "open a session SITE:SUBJECT for the files")
                    ->check(utf8_text());
  session->excludes(fresh);
  fresh->excludes(session);
  command->add_option("--format", args->format, "csv or cgats (default: recognised from each file's content)")
      ->check(CLI::IsMember({"csv", "cgats"}));
  add_scale_option(*command, args->scale, "; a CGATS file gives its own (SPECTRAL_NORM)");
  auto* model = add_model_option(*command, args->model);
  model->needs(fresh);  // an existing session's model is its own
  add_server_options(*command, *server);
  command->callback([server, args, session, fresh] {
    if (session->count() == 0 && fresh->count() == 0)
      throw Failure{kBadInput, "import: give --session ID or --new-session SITE:SUBJECT"};
    run_import(*server, *args);
  });
}

}  // namespace skinspec::cli
