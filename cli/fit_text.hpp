#pragma once
// A fit as the service returns it (JSON), for the session commands' tables: its parameters in
// its model's order, and what the spectrum did not determine.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace skinspec::cli {

// The names of the fit's parameters in its model's order (the order of its JSON object when the
// model is not one this version knows).
std::vector<std::string> param_names(const nlohmann::json& fit);

// Why the spectrum did not determine the parameter ("at_bound", "correlated with melanin", ...);
// nullopt when it did.
std::optional<std::string> not_determined(const nlohmann::json& fit, const std::string& name);

}  // namespace skinspec::cli
