#pragma once
// The one place where the fitter's results and the store's fit records meet: a FitResult as a
// store::Fit (for the service's refits and the daemon's measurement jobs) and back (for the
// stored fit's JSON, renders and exports).

#include <expected>
#include <string>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::records {

// The software a stored fit names as its model_version: "skinspec <version>".
std::string model_version();

// `result` as the store keeps it: its model and parameters by name, what the spectrum
// determined, the options it was fitted with ({"site", "lateral_diffusion"}), model_version()
// and the digests of the tables and constants of `optics` (the model that fitted it). The
// caller sets measurement_id (record_measurement does it for a fit stored with its measurement).
store::Fit to_store_fit(const FitResult& result, const FitOptions& options, const SkinOptics& optics);

// `reflectance` fitted with `options` and made a store fit as above (measurement_id unset), or
// why the fitter refused it.
std::expected<store::Fit, std::string> fitted(const Fitter& fitter, const store::SpectralSamples& reflectance,
                                              const FitOptions& options);

// A stored fit's values as the fitter gave them; an error when its model is not one this
// version knows or its parameters are not that model's.
std::expected<FitResult, std::string> to_fit_result(const store::Fit& fit);

}  // namespace skinspec::records
