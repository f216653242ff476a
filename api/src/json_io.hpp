#pragma once
// Reading request bodies strictly and writing records as JSON. Failures throw HandlerError,
// which the router turns into one error response.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/api/errors.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

struct HandlerError {
  ApiError error;
};
[[noreturn]] void fail(ErrorKind kind, std::string code, std::string message);
// A StoreError as the service reports it (not_found → 404, conflict → 409, busy → 503, ...).
[[noreturn]] void fail_store(const store::StoreError& error);

// The body as a JSON object: 400 for invalid UTF-8 or malformed JSON, 422 for another type.
nlohmann::json parse_object(const std::string& body);
// 422 when `object` has a member not in `allowed`.
void only_fields(const nlohmann::json& object, std::initializer_list<const char*> allowed);

std::optional<std::string> optional_string(const nlohmann::json& object, const char* key, std::size_t max_length);
std::string required_string(const nlohmann::json& object, const char* key, std::size_t max_length);
std::optional<bool> optional_bool(const nlohmann::json& object, const char* key);
std::optional<store::Id> optional_id(const nlohmann::json& object, const char* key);
// An array of finite numbers, each within [min, max], with 2..max_size elements.
std::vector<double> number_array(const nlohmann::json& value, const std::string& name, double min, double max,
                                 std::size_t max_size);

nlohmann::json to_json(const store::WhiteStandard& standard);
nlohmann::json to_json(const store::Session& session);
nlohmann::json to_json(const store::Measurement& measurement, std::optional<store::Id> fit_id);
// Without the raw reply bytes (they are in the store and its export, not in listings).
nlohmann::json to_json(const store::RejectedReading& reading);
// The fields of `skinspec fit` (fit_to_json), plus the stored record's id and provenance.
nlohmann::json to_json(const store::Fit& fit);
store::Fit to_store_fit(const FitResult& result, const nlohmann::json& options, const std::string& model_version,
                        const std::string& tables_digest);

std::string dump(const nlohmann::json& value);

}  // namespace skinspec::api::detail
