#pragma once
// The JSON form of fit results, shared by the command line and the service so that both
// print exactly the same fields.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/fit/fitter.hpp"

namespace skinspec {

// Fields of `skinspec fit`: name, model, site, params, stderr, rmse, max_abs_error,
// delta_e00_d65, iterations, converged, samples_ignored, wavelength_nm, measured, fitted; and,
// for a fit that judged its parameters, determination, derived (oxygen_saturation,
// blood_volume_fraction) and correlation; note when the spectrum covered less than the model's
// range; skin_tone ({ita_deg, ita_class, melanin_index, erythema_index}, the measured spectrum's);
// termination, how the solver ended, wherever it is known. A standard error is null
// where the spectrum does not determine the parameter, and determination says why.
nlohmann::json fit_to_json(std::string_view name, const FitResult& fit);

// What the spectrum determined and how the solver ended, as fit_to_json gives it:
// {correlation, derived, determination, note, skin_tone, termination}, each only when the fit has it; the
// stored form of a fit's judgement, written directly as text, keys sorted as the JSON library
// keeps them. Its numbers read back exactly, though not always in the library's words (1e-04
// where it writes 0.0001).
std::string assessment_text(const FitResult& fit);
// The same as JSON values.
nlohmann::json assessment_to_json(const FitResult& fit);

// The options a fit was made with, as a stored fit keeps them: {"lateral_diffusion", "site"},
// written directly as text like assessment_text.
std::string options_text(const FitOptions& options);

// Reads assessment_to_json's object back into `fit` (whose model and params are set): its
// determination, derived quantities, correlation, note, skin tone and termination. A field that is absent
// stays empty (a fit stored before fits were judged); false when a field is malformed.
bool assessment_from_json(const nlohmann::json& assessment, FitResult& fit);

// A fit's "skin_tone" object read back; nullopt when it is malformed.
std::optional<SkinTone> skin_tone_from_json(const nlohmann::json& j);

// {name: value} in the model's parameter order; non-finite values are null.
nlohmann::json params_to_json(ModelKind model, const Params& params);

}  // namespace skinspec
