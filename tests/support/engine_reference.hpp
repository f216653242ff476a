#pragma once
// The fit engine's answers on the 50 NIST forearms of data/real-skin/, as text, so that a
// change meant to make the engine faster can be checked to give the same answers
// (tests/fit/engine_reference_test.cpp against tests/data/engine-reference/, written by
// write_engine_reference).

#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"

namespace skinspec::testing {

// One quantity of one fit: `value` is a number written with 17 significant digits ("inf",
// "-inf" and "nan" as such) or a word (a determination verdict).
struct EngineAnswer {
  std::string model, spectrum, quantity, value;
};

// Every quantity the fit reports of each of the 50 forearms, fitted by the shipped `model`
// with default options (forearm site, lateral diffusion on).
std::vector<EngineAnswer> engine_answers(ModelKind model);

// The file format: a header line, then model,spectrum,quantity,value per line. Lines that
// start with '#' are comments.
std::string to_csv(const std::vector<EngineAnswer>& answers);
std::vector<EngineAnswer> parse_engine_answers(const std::string& csv);

}  // namespace skinspec::testing
