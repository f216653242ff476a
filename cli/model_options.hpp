#pragma once
// Options that name a skin model and its parameters: --model, one option per parameter of any
// model (checked against the chosen one after parsing), and --fix.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common.hpp"

namespace skinspec::cli {

// --model paper|extended.
CLI::Option* add_model_option(CLI::App& app, ModelKind& model);

// Parameter values given on the command line, by parameter name.
struct ParamArgs {
  std::map<std::string, double> given;
};

// --surface-reflectance (or --surface), --melanin, ...: every parameter of every model, each
// checked against the range its equations hold for. Returns the options added.
std::vector<CLI::Option*> add_param_options(CLI::App& app, ParamArgs& args);

// `model`'s parameters: its defaults, overridden by those given; a Failure naming an option
// that belongs to another model.
Params params_for(ModelKind model, const ParamArgs& args);

// --fix NAME[=VALUE], repeatable: hold a parameter at VALUE (its default when omitted).
CLI::Option* add_fix_option(CLI::App& app, std::vector<std::string>& fixes);
std::vector<std::pair<std::size_t, double>> held_for(ModelKind model, const std::vector<std::string>& fixes);

}  // namespace skinspec::cli
