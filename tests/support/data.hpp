#pragma once
// Test helpers: the project's tables, loaded once per test program.

#include <string>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/fit/optics.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec::testing {

// Contents of a file under the source tree's data/ (fails the test program when missing).
std::string data_file(const std::string& relative);
// The table under data/ at `relative`, parsed.
Table table(const std::string& relative);
const Colorimetry& colorimetry();

// A DataReader over the source tree's data/.
DataReader source_data_reader();

// The shipped tables and a model's constants, loaded once. data/model/constants*.csv are
// re-tuned from time to time, so what is checked on these must hold for any constants.
const SkinOptics& shipped_optics(ModelKind model = ModelKind::paper);

// The shipped tables under fixed textbook constants (every scale 1) and a lateral radius of
// 2 mm, typical of a contact probe, so that the lateral-diffusion path is exercised. Properties
// that need the skin to behave like skin (the dermis seen through the epidermis, red light lost
// sideways) are checked on these: the tuner may move the shipped constants far while it
// searches, and such properties are about the code, not about the tuning.
const SkinOptics& textbook_optics(ModelKind model = ModelKind::paper);

// A fitter of every model with the shipped constants.
const Fitter& shipped_fitter();

}  // namespace skinspec::testing
