#pragma once
// Reading request bodies strictly. Failures throw HandlerError, which the router turns into one
// error response. The records' JSON is records/record_json.hpp.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/api/errors.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

struct HandlerError {
  ApiError error;
};
[[noreturn]] void fail(ErrorKind kind, std::string code, std::string message);
// A StoreError as the service reports it (from_store_error).
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

std::string dump(const nlohmann::json& value);

}  // namespace skinspec::api::detail
