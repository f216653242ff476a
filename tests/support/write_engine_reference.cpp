// Writes the fit engine's answers on the 50 NIST forearms (support/engine_reference.hpp) for
// one model to standard output: how tests/data/engine-reference/*.csv were made.
// Usage: write_engine_reference paper|extended "COMMENT" > FILE

#include <cstdio>
#include <string>

#include "support/engine_reference.hpp"

int main(int argc, char** argv) {
  using namespace skinspec;
  const auto model = argc == 3 ? parse_model_kind(argv[1]) : std::nullopt;
  if (!model) {
    std::fprintf(stderr, "usage: write_engine_reference %s \"COMMENT\" > FILE\n", model_names().c_str());
    return 2;
  }
  std::string out = "# " + std::string(argv[2]) + "\n";
  out += testing::to_csv(testing::engine_answers(*model));
  std::fwrite(out.data(), 1, out.size(), stdout);
  return 0;
}
