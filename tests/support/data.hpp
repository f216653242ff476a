#pragma once
// Test helpers: the project's tables, loaded once per test program.

#include <string>

#include "skinspec/fit/colour.hpp"
#include "skinspec/fit/table.hpp"

namespace skinspec::testing {

// Contents of a file under the source tree's data/ (fails the test program when missing).
std::string data_file(const std::string& relative);
// The table under data/ at `relative`, parsed.
Table table(const std::string& relative);
const Colorimetry& colorimetry();

}  // namespace skinspec::testing
