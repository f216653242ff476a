#pragma once
// What a stored fit's parameters must be, written as rules over nlohmann::json's parsed
// document: the store's decoder (store/src/codec.hpp) reads them without one, and must accept
// and refuse the same texts and read the same names and values (tests/store/store_codec_test.cpp,
// tests/fuzz/fit_params_fuzz.cpp).

#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/store/types.hpp"

namespace skinspec::testing {

inline std::optional<std::vector<store::FitParam>> fit_params_through_a_document(std::string_view text) {
  const auto parsed = nlohmann::json::parse(text, nullptr, false);
  if (parsed.is_discarded() || !parsed.is_array() || parsed.empty()) return std::nullopt;
  std::vector<store::FitParam> params;
  for (const auto& item : parsed) {
    if (!item.is_object() || !item.contains("name") || !item["name"].is_string() || !item.contains("value") ||
        !item["value"].is_number() || !item.contains("standard_error"))
      return std::nullopt;
    const auto& se = item["standard_error"];
    if (!se.is_null() && !se.is_number()) return std::nullopt;
    params.push_back({item["name"].get<std::string>(), item["value"].get<double>(),
                      se.is_null() ? std::numeric_limits<double>::infinity() : se.get<double>()});
  }
  return params;
}

}  // namespace skinspec::testing
