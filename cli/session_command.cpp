// skinspec session new|measure|show|list: acquisition sessions of a running skinspecd, over
// its HTTP API.

#include <fmt/format.h>

#include <algorithm>
#include <iostream>

#include "common.hpp"
#include "fit_json.hpp"
#include "fit_text.hpp"
#include "model_options.hpp"
#include "session_client.hpp"

namespace skinspec::cli {

namespace {

using nlohmann::json;

std::string text_or(const json& value, const std::string& fallback = "-") {
  if (value.is_string()) return value.get<std::string>().empty() ? fallback : printable(value.get<std::string>());
  if (value.is_null()) return fallback;
  return value.dump();
}

struct NewArgs {
  std::string site, subject = "anonymous", operator_name, notes;
  ModelKind model = kDefaultModel;
  long long white_standard = 0;
};

void run_new(const ServerArgs& server, const NewArgs& args) {
  json body = {{"site", args.site}, {"subject", args.subject}, {"model", to_string(args.model)}};
  if (!args.operator_name.empty()) body["operator"] = args.operator_name;
  if (!args.notes.empty()) body["notes"] = args.notes;
  if (args.white_standard > 0) body["white_standard_id"] = args.white_standard;
  const auto client = server.client();
  const json session = client.call("POST", "/api/v1/sessions", body);
  if (server.json) {
    std::cout << session.dump() << '\n';
    return;
  }
  std::cout << fmt::format("session {} opened: site {}, subject {}, model {}\n", session["id"].get<long long>(),
                           text_or(session["site"]), text_or(session["subject"]), text_or(session["model"]));
  std::cout << fmt::format("url: {}/api/v1/sessions/{}\n", client.server().text, session["id"].get<long long>());
}

// A fit's parameter as a table shows it: "n.d." where the spectrum did not determine it.
std::string param_cell(const json& fit, const std::string& name) {
  if (not_determined(fit, name)) return "n.d.";
  const auto& v = fit["params"][name];
  return v.is_number() ? fmt::format("{:.4g}", v.get<double>()) : std::string("-");
}

// The session's fits of one model, one column per parameter of that model; the units above,
// what "n.d." means below.
void print_fits(const json& fits, const std::string& model) {
  const auto names = param_names({{"model", model}});
  std::string header = fmt::format("\nfits, model {}\n{}\n{:>6} {:>11}", model,
                                   units_line(model, names, "rmse", "dE2000"), "fit", "measurement");
  for (const auto& name : names) header += fmt::format(" {:>{}}", name, std::max<std::size_t>(9, name.size()));
  std::cout << header << fmt::format(" {:>8} {:>7}{}\n", "rmse", "dE2000", skin_tone_header());
  for (const auto& f : fits) {
    if (text_or(f["model"]) != model) continue;
    std::string row = fmt::format("{:>6} {:>11}", f["id"].get<long long>(), f["measurement_id"].get<long long>());
    for (const auto& name : names)
      row += fmt::format(" {:>{}}", param_cell(f, name), std::max<std::size_t>(9, name.size()));
    const auto tone = f.contains("skin_tone") ? skin_tone_from_json(f["skin_tone"]) : std::nullopt;
    std::cout << row
              << fmt::format(" {:>8.4f} {:>7.2f}{}\n", f.value("rmse", 0.0), f.value("delta_e00_d65", 0.0),
                             skin_tone_cells(tone));
  }
  std::cout << not_determined_line("--json") << '\n';
}

void print_session_detail(const json& s) {
  std::cout << fmt::format("session {}  {}  site {}  subject {}  operator {}  model {}\n", s["id"].get<long long>(),
                           text_or(s["state"]), text_or(s["site"]), text_or(s["subject"]), text_or(s["operator"]),
                           text_or(s["model"]));
  std::cout << fmt::format("created {}  white standard {}\n", text_or(s["created_at"]),
                           text_or(s["white_standard_id"], "default (flat 0.99)"));
  if (const auto notes = text_or(s["notes"], ""); !notes.empty()) std::cout << "notes: " << notes << '\n';
  std::cout << fmt::format("\n{:>6} {:<7} {:<16} {:>8} {:>6}  {}\n", "id", "kind", "label", "readings", "fit",
                           "created");
  for (const auto& m : s["measurements"])
    std::cout << fmt::format("{:>6} {:<7} {:<16} {:>8} {:>6}  {}\n", m["id"].get<long long>(), text_or(m["kind"]),
                             text_or(m["label"], ""), text_or(m["reading_count"]), text_or(m["fit_id"]),
                             text_or(m["created_at"]));
  std::vector<std::string> models;
  for (const auto& f : s["fits"])
    if (const auto m = text_or(f["model"]); std::ranges::find(models, m) == models.end()) models.push_back(m);
  for (const auto& model : models) print_fits(s["fits"], model);
}

void run_show(const ServerArgs& server, long long id) {
  const json session = server.client().call("GET", "/api/v1/sessions/" + std::to_string(id));
  if (server.json) std::cout << session.dump() << '\n';
  else print_session_detail(session);
}

struct ListArgs {
  std::string site, state;
  int limit = 50;
};

void run_list(const ServerArgs& server, const ListArgs& args) {
  std::string target = "/api/v1/sessions?limit=" + std::to_string(args.limit);
  if (!args.site.empty()) target += "&site=" + url_encode(args.site);
  if (!args.state.empty()) target += "&state=" + url_encode(args.state);
  const json page = server.client().call("GET", target);
  if (server.json) {
    std::cout << page.dump() << '\n';
    return;
  }
  if (page["sessions"].empty()) {
    std::cout << "no sessions\n";
    return;
  }
  std::cout << fmt::format("{:>6} {:<11} {:<13} {:<20} {:<16} {}\n", "id", "state", "site", "subject", "operator",
                           "created");
  for (const auto& s : page["sessions"])
    std::cout << fmt::format("{:>6} {:<11} {:<13} {:<20} {:<16} {}\n", s["id"].get<long long>(), text_or(s["state"]),
                             text_or(s["site"]), text_or(s["subject"]), text_or(s["operator"]),
                             text_or(s["created_at"]));
  if (!page["next_cursor"].is_null()) std::cout << "(more: the API's cursor " << page["next_cursor"] << ")\n";
}

}  // namespace

void add_server_options(CLI::App& command, ServerArgs& args) {
  command.add_option("--server", args.server, "skinspecd's URL: http:// or https://")->capture_default_str();
  command.add_option("--ca-file", args.ca_file,
                     "PEM file of the CA an https:// server's certificate must chain to (else the system's CAs)");
  command.add_option("--token-file", args.token_file,
                     "a file holding the bearer token, or skinspecd's old two-token file (else $SKINSPEC_TOKEN)");
  command.add_flag("--json", args.json, "print the server's JSON instead of text");
}

void add_session_command(CLI::App& app) {
  auto* session =
      app.add_subcommand("session", "acquisition sessions of a running skinspecd: new, measure, show, list");
  session->require_subcommand(1);
  auto server = std::make_shared<ServerArgs>();

  auto new_args = std::make_shared<NewArgs>();
  auto* create = session->add_subcommand("new", "open a session");
  create->add_option("--site", new_args->site, "body site: forearm, back_of_hand, cheek, forehead, palm")
      ->required()
      ->check(utf8_text());
  create->add_option("--subject", new_args->subject, "who is measured (a code, not a name)")
      ->capture_default_str()
      ->check(utf8_text());
  create->add_option("--operator", new_args->operator_name, "who measures")->check(utf8_text());
  create
      ->add_option("--white-standard", new_args->white_standard, "id of a stored white standard (default: a flat 0.99)")
      ->check(CLI::PositiveNumber);
  create->add_option("--notes", new_args->notes, "free text")->check(utf8_text());
  add_model_option(*create, new_args->model);
  add_server_options(*create, *server);
  create->callback([server, new_args] { run_new(*server, *new_args); });

  add_session_measure_command(*session, server);

  auto show_id = std::make_shared<long long>(0);
  auto* show = session->add_subcommand("show", "a session with its measurements and fits");
  show->add_option("SESSION_ID", *show_id, "session id")->required()->check(CLI::PositiveNumber);
  add_server_options(*show, *server);
  show->callback([server, show_id] { run_show(*server, *show_id); });

  auto list_args = std::make_shared<ListArgs>();
  auto* list = session->add_subcommand("list", "sessions, newest first");
  list->add_option("--site", list_args->site, "only this body site")->check(utf8_text());
  list->add_option("--state", list_args->state, "only this state")
      ->check(CLI::IsMember({"open", "complete", "interrupted", "aborted"}));
  list->add_option("--limit", list_args->limit, "at most this many")->check(CLI::Range(1, 1000))->capture_default_str();
  add_server_options(*list, *server);
  list->callback([server, list_args] { run_list(*server, *list_args); });
}

}  // namespace skinspec::cli
