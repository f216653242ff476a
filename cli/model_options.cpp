#include "model_options.hpp"

#include <algorithm>
#include <charconv>
#include <fmt/format.h>
#include <fmt/ranges.h>

namespace skinspec::cli {

namespace {

std::string option_name(std::string_view param) {
  std::string name(param);
  std::ranges::replace(name, '_', '-');
  return "--" + name;
}

std::string param_list(ModelKind model) {
  std::vector<std::string_view> names;
  for (const ParamSpec& spec : model_spec(model).params) names.push_back(spec.name);
  return fmt::format("{}", fmt::join(names, ", "));
}

// The spec of a parameter name in the first model that has it.
const ParamSpec* any_spec(std::string_view name) {
  for (const ModelKind kind : kModelKinds)
    if (const auto i = param_index(kind, name)) return &model_spec(kind).params[*i];
  return nullptr;
}

}  // namespace

CLI::Option* add_model_option(CLI::App& app, ModelKind& model) {
  std::vector<std::string> names;
  for (const ModelKind kind : kModelKinds) names.emplace_back(to_string(kind));
  return app
      .add_option_function<std::string>(
          "--model", [&model](const std::string& name) { model = *parse_model_kind(name); },
          "skin model: " + model_names() + " (docs/model.md)")
      ->check(CLI::IsMember(names))
      ->default_str(std::string(to_string(kDefaultModel)));
}

std::vector<CLI::Option*> add_param_options(CLI::App& app, ParamArgs& args) {
  std::vector<std::string_view> seen;
  std::vector<CLI::Option*> added;
  for (const ModelKind kind : kModelKinds)
    for (const ParamSpec& spec : model_spec(kind).params) {
      if (std::ranges::find(seen, spec.name) != seen.end()) continue;
      seen.push_back(spec.name);
      const std::string name(spec.name);
      std::string flags = option_name(spec.name);
      if (spec.name == "surface_reflectance") flags += ",--surface";
      const ParamSpec* s = any_spec(spec.name);
      auto* option = app.add_option_function<double>(
          flags, [&args, name](double value) { args.given[name] = value; }, fmt::format("{} ({})", name, s->unit));
      option->check(finite_range(s->domain_lower, s->domain_upper));
      added.push_back(option);
    }
  return added;
}

Params params_for(ModelKind model, const ParamArgs& args) {
  Params p = default_params(model);
  for (const auto& [name, value] : args.given) {
    const auto i = param_index(model, name);
    if (!i)
      throw Failure{kBadInput, fmt::format("{} is not a parameter of the {} model, whose parameters are {}",
                                           option_name(name), to_string(model), param_list(model))};
    const ParamSpec& spec = model_spec(model).params[*i];
    if (!(value >= spec.domain_lower && value <= spec.domain_upper))
      throw Failure{kBadInput, fmt::format("{} must be in [{}, {}] for the {} model, not {}", option_name(name),
                                           spec.domain_lower, spec.domain_upper, to_string(model), value)};
    p[*i] = value;
  }
  return p;
}

CLI::Option* add_fix_option(CLI::App& app, std::vector<std::string>& fixes) {
  return app.add_option("--fix", fixes,
                        "hold a parameter instead of fitting it: NAME=VALUE, or NAME for its default (repeatable)");
}

std::vector<std::pair<std::size_t, double>> held_for(ModelKind model, const std::vector<std::string>& fixes) {
  std::vector<std::pair<std::size_t, double>> held;
  for (const std::string& fix : fixes) {
    const auto equals = fix.find('=');
    const std::string name = fix.substr(0, equals);
    const auto i = param_index(model, name);
    if (!i)
      throw Failure{kBadInput, fmt::format("--fix {}: the {} model has no parameter '{}'; its parameters are {}", fix,
                                           to_string(model), name, param_list(model))};
    double value = model_spec(model).params[*i].initial;
    if (equals != std::string::npos) {
      const std::string text = fix.substr(equals + 1);
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (ec != std::errc{} || end != text.data() + text.size() || text.empty())
        throw Failure{kBadInput, fmt::format("--fix {}: '{}' is not a number", fix, text)};
    }
    held.emplace_back(*i, value);
  }
  return held;
}

}  // namespace skinspec::cli
