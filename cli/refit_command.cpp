// skinspec refit --db PATH|URI [--model M] [--session ID]: stored measurements fitted again with
// the current model and constants, the new fits stored beside the old (records/refit.hpp). Run
// again after a stop or a kill, it refits only what was not yet refitted.

#include <fmt/format.h>

#include <iostream>

#include "common.hpp"
#include "model_options.hpp"
#include "skinspec/records/refit.hpp"

namespace skinspec::cli {

namespace {

struct RefitArgs {
  std::string db;
  ModelKind model = kDefaultModel;
  std::optional<store::Id> session;
};

std::string progress_line(const records::RefitProgress& p) {
  auto line = fmt::format("refit: {} of {} refitted", p.done, p.total);
  if (p.failed > 0) line += fmt::format(", {} refused", p.failed);
  line += fmt::format(", {:.1f} s", p.elapsed_s);
  if (p.remaining_s) line += fmt::format(", about {:.0f} s left", *p.remaining_s);
  return line;
}

void run_refit(const RefitArgs& args) {
  store::OpenOptions options;
  options.create_missing = false;
  auto opened = store::Store::open(args.db, options);
  if (!opened) throw store_failure(opened.error());
  auto& db = *opened;
  if (args.session)
    if (auto session = db.session(*args.session); !session) throw store_failure(session.error());
  const records::RefitRequest request{args.model, args.session, true};
  const auto report = records::refit(db, fitter(), request, [](const records::RefitProgress& p) {
    std::cerr << progress_line(p) << '\n';
    return true;
  });
  if (!report) throw store_failure(report.error());
  const auto maker = records::current_fit_maker(fitter(), args.model);
  std::cout << fmt::format("refitted {} of {} measurements with the {} model ({}, constants {})\n",
                           report->progress.done, report->progress.total, maker.model, maker.model_version,
                           maker.constants_digest);
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
  if (report->progress.failed > 0) {
    std::string message =
        fmt::format("{} measurements could not be fitted (nothing stored for them):", report->progress.failed);
    for (const auto& failure : report->failures) message += "\n  " + failure;
    throw Failure{kBadInput, message};
  }
}

}  // namespace

void add_refit_command(CLI::App& app) {
  auto args = std::make_shared<RefitArgs>();
  auto* command = app.add_subcommand(
      "refit", "fit stored measurements again with the current model and constants, beside their earlier fits");
  command
      ->add_option("--db", args->db, "the skinspec database, a file or a postgresql:// URI (not in use by skinspecd)")
      ->required();
  add_model_option(*command, args->model);
  command->add_option("--session", args->session, "refit one session's measurements (default: every session's)");
  command->callback([args] { run_refit(*args); });
}

}  // namespace skinspec::cli
