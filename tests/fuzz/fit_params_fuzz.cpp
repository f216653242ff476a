// libFuzzer target: arbitrary bytes as a stored fit's parameters, read by the store's decoder
// (store/src/codec.hpp), which reads them without building a document, and by the rules written
// over nlohmann::json's parsed document: both must accept and refuse the same inputs and read
// the same names and values. Build and run with scripts/fuzz.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string_view>
#include <vector>

#include "codec.hpp"
#include "db.hpp"
#include "support/fit_params_document.hpp"

namespace {

using skinspec::store::FitParam;

bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto expected = skinspec::testing::fit_params_through_a_document(text);
  std::optional<std::vector<FitParam>> read;
  try {
    read = skinspec::store::detail::decode_fit_params(text, "fuzzed");
  } catch (const skinspec::store::detail::Failure&) {
  }
  if (read.has_value() != expected.has_value()) {
    std::fprintf(stderr, "the decoder %s, the document rules %s\n", read ? "accepts" : "refuses",
                 expected ? "accept" : "refuse");
    std::abort();
  }
  if (!read) return 0;
  bool agree = read->size() == expected->size();
  for (std::size_t i = 0; agree && i < read->size(); ++i) {
    const auto& a = (*read)[i];
    const auto& b = (*expected)[i];
    agree = a.name == b.name && same(a.value, b.value) && same(a.standard_error, b.standard_error);
  }
  if (!agree) {
    std::fprintf(stderr, "the decoder and the document rules read different parameters\n");
    std::abort();
  }
  return 0;
}
