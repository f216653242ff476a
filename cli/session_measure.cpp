// skinspec session measure: queues a white or sample measurement on skinspecd, follows the
// job's events (a progress bar on a terminal, one line per change otherwise, both on stderr)
// and prints the result: for a sample the fitted parameters with their standard errors.

#include <fmt/format.h>
#include <iostream>

#include "common.hpp"
#include "fit_text.hpp"
#include "job_follow.hpp"
#include "session_client.hpp"
#include "skinspec/fit/model_spec.hpp"

namespace skinspec::cli {

namespace {

using nlohmann::json;

struct SessionMeasureArgs {
  long long session = 0;
  std::string kind;
  int count = 1;
  std::string label;
  int integration_ms = 0;
  bool no_wait = false;
};

std::string id_text(const json& value) {
  return value.is_number_integer() ? std::to_string(value.get<long long>()) : "-";
}

// One parameter a line with its unit; "n.d." and why where the spectrum did not determine it.
void print_fit(const json& fit) {
  const std::string model = fit.value("model", "-");
  std::cout << fmt::format("  model {}\n", model);
  bool any_not_determined = false;
  for (const auto& name : param_names(fit)) {
    const json& value = fit["params"][name];
    const json& error = fit["stderr"][name];
    std::string line;
    if (const auto reason = not_determined(fit, name)) {
      line = fmt::format("  {:<24} {:>12} ({})", name, "n.d.", *reason);
      any_not_determined = true;
    } else if (value.is_number()) {
      line = fmt::format("  {:<24} {:>12.6g}", name, value.get<double>());
      if (error.is_number()) line += fmt::format(" ± {:.6g}", error.get<double>());
    } else {
      continue;
    }
    if (const auto unit = param_unit(model, name); !unit.empty()) line += "  " + unit;
    std::cout << line << '\n';
  }
  std::cout << fmt::format("  rmse {:.6g}   max |error| {:.6g} {}   dE2000 (D65) {:.6g}   converged {}\n",
                           fit.value("rmse", 0.0), fit.value("max_abs_error", 0.0), unit_text(kRmseUnit),
                           fit.value("delta_e00_d65", 0.0), fit.value("converged", false));
  if (any_not_determined) std::cout << "  " << not_determined_line({}) << '\n';
}

void print_result(const json& job, const json& fit) {
  const json& result = job["result"];
  std::cout << fmt::format("job {} succeeded: measurement {}", job.value("id", 0LL), id_text(result["measurement_id"]));
  if (result.contains("white_measurement_id") && result["white_measurement_id"].is_number_integer())
    std::cout << fmt::format(" (white {})", id_text(result["white_measurement_id"]));
  if (result.contains("fit_id") && result["fit_id"].is_number_integer())
    std::cout << ", fit " << id_text(result["fit_id"]);
  std::cout << '\n';
  if (fit.is_object()) print_fit(fit);
  if (result.contains("warnings"))
    for (const auto& w : result["warnings"]) std::cout << "warning: " << w.get<std::string>() << '\n';
}

void run_measure(const ServerArgs& server, const SessionMeasureArgs& args) {
  const auto client = server.client();
  json body = {{"kind", args.kind}, {"count", args.count}};
  if (!args.label.empty()) body["label"] = args.label;
  if (args.integration_ms != 0) body["integration_ms"] = args.integration_ms;
  const json accepted = client.call("POST", "/api/v1/sessions/" + std::to_string(args.session) + "/measurements", body);
  const long long job_id = accepted.value("id", 0LL);
  if (args.no_wait) {
    if (server.json) std::cout << accepted.dump() << '\n';
    else std::cout << fmt::format("job {} queued: {}/api/v1/jobs/{}\n", job_id, client.server().text, job_id);
    return;
  }
  const json job = follow_job(client, job_id);
  if (job["state"] != "succeeded")
    throw Failure{kInstrumentError,
                  fmt::format("job {} {}: {}", job_id, job["state"].get<std::string>(), job_error_text(job["error"]))};
  json fit = nullptr;
  if (const auto& id = job["result"]["fit_id"]; id.is_number_integer())
    fit = client.call("GET", "/api/v1/fits/" + std::to_string(id.get<long long>()));
  if (server.json) std::cout << json{{"job", job}, {"fit", fit}}.dump() << '\n';
  else print_result(job, fit);
}

}  // namespace

void add_session_measure_command(CLI::App& session, const std::shared_ptr<ServerArgs>& server) {
  auto args = std::make_shared<SessionMeasureArgs>();
  auto* measure = session.add_subcommand("measure", "measure the white standard or the skin, and wait for the result");
  measure->add_option("SESSION_ID", args->session, "session id")->required()->check(CLI::PositiveNumber);
  measure->add_option("--kind", args->kind, "white or sample")->required()->check(CLI::IsMember({"white", "sample"}));
  measure->add_option("--count", args->count, "readings averaged")->check(CLI::Range(1, 100))->capture_default_str();
  measure->add_option("--label", args->label, "a label for the measurement")->check(utf8_text());
  measure
      ->add_option("--integration-ms", args->integration_ms,
                   "integration time in ms, within the meter's range (default: adaptive)")
      ->check(CLI::Range(1, 3600000));
  measure->add_flag("--no-wait", args->no_wait, "print the queued job and return at once");
  add_server_options(*measure, *server);
  measure->callback([server, args] { run_measure(*server, *args); });
}

}  // namespace skinspec::cli
