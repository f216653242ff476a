// libFuzzer target: arbitrary bytes into the store's JSON syntax check (store/src/json_syntax.hpp)
// and into nlohmann::json::accept, which must agree on every input, for a value of any kind and
// for an object. Build and run with scripts/fuzz.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string_view>

#include "json_syntax.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const bool expected = nlohmann::json::accept(text);
  if (skinspec::store::detail::is_json(text) != expected) {
    std::fprintf(stderr, "is_json says %d, nlohmann::json::accept %d\n", !expected, expected);
    std::abort();
  }
  const bool object = expected && nlohmann::json::parse(text).is_object();
  if (skinspec::store::detail::is_json_object(text) != object) {
    std::fprintf(stderr, "is_json_object says %d, nlohmann::json %d\n", !object, object);
    std::abort();
  }
  return 0;
}
