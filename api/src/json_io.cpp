#include "json_io.hpp"

#include <cmath>
#include <set>

#include "skinspec/spectral/utf8.hpp"
#include "text.hpp"

namespace skinspec::api::detail {

using nlohmann::json;

void fail(ErrorKind kind, std::string code, std::string message) {
  throw HandlerError{ApiError{kind, std::move(code), std::move(message)}};
}

void fail_store(const store::StoreError& error) { throw HandlerError{from_store_error(error)}; }

json parse_object(const std::string& body) {
  if (!utf8::is_valid(body)) fail(ErrorKind::bad_request, "invalid_utf8", "the body is not valid UTF-8");
  // The keys of each object being read, innermost last: a repeated key is refused rather
  // than letting the last one win, which would hide what the client meant.
  std::vector<std::set<std::string>> open_objects;
  std::optional<std::string> repeated;
  const auto watch_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) open_objects.emplace_back();
    else if (event == json::parse_event_t::object_end && !open_objects.empty()) open_objects.pop_back();
    else if (event == json::parse_event_t::key && !open_objects.empty() && !repeated &&
             !open_objects.back().insert(parsed.get<std::string>()).second)
      repeated = parsed.get<std::string>();
    return true;
  };
  json value = json::parse(body, watch_keys, false);
  if (value.is_discarded()) fail(ErrorKind::bad_request, "malformed_json", "the body is not well-formed JSON");
  if (repeated) {
    constexpr std::size_t kShown = 100;
    const std::string shown = repeated->size() > kShown ? repeated->substr(0, kShown) + "..." : *repeated;
    fail(ErrorKind::bad_request, "duplicate_key", "the key '" + shown + "' appears twice in one object");
  }
  if (!value.is_object()) fail(ErrorKind::unprocessable, "wrong_type", "the body must be a JSON object");
  return value;
}

void only_fields(const json& object, std::initializer_list<const char*> allowed) {
  for (const auto& item : object.items()) {
    bool known = false;
    for (const char* name : allowed) known = known || item.key() == name;
    if (!known) fail(ErrorKind::unprocessable, "unknown_field", "unknown field '" + item.key() + "'");
  }
}

std::optional<std::string> optional_string(const json& object, const char* key, std::size_t max_length) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_string()) fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be a string");
  auto text = it->get<std::string>();
  if (text.size() > max_length)
    fail(ErrorKind::unprocessable, "too_long",
         std::string("'") + key + "' is longer than " + std::to_string(max_length) + " bytes");
  return text;
}

std::string required_string(const json& object, const char* key, std::size_t max_length) {
  auto text = optional_string(object, key, max_length);
  if (!text) fail(ErrorKind::unprocessable, "missing_field", std::string("'") + key + "' is required");
  if (text->empty()) fail(ErrorKind::unprocessable, "invalid_value", std::string("'") + key + "' must not be empty");
  return *text;
}

std::optional<bool> optional_bool(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_boolean())
    fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be true or false");
  return it->get<bool>();
}

std::optional<store::Id> optional_id(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_number_integer() || it->get<std::int64_t>() <= 0 ||
      (it->is_number_unsigned() && it->get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)))
    fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be a positive integer id");
  return it->get<store::Id>();
}

std::vector<double> number_array(const json& value, const std::string& name, double min, double max,
                                 std::size_t max_size) {
  if (!value.is_array()) fail(ErrorKind::unprocessable, "wrong_type", "'" + name + "' must be an array of numbers");
  if (value.size() < 2 || value.size() > max_size)
    fail(ErrorKind::unprocessable, "invalid_length",
         "'" + name + "' must have 2 to " + std::to_string(max_size) + " values, not " + std::to_string(value.size()));
  std::vector<double> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    const json& v = value[i];
    if (!v.is_number())
      fail(ErrorKind::unprocessable, "wrong_type", "'" + name + "'[" + std::to_string(i) + "] is not a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < min || x > max)
      fail(ErrorKind::unprocessable, "out_of_range",
           "'" + name + "'[" + std::to_string(i) + "] must be finite and within [" + json(min).dump() + ", " +
               json(max).dump() + "]");
    out.push_back(x);
  }
  return out;
}

std::string dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

}  // namespace skinspec::api::detail
