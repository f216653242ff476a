#pragma once
// The one place where the fitter's results and the store's fit records meet: a FitResult as a
// store::Fit (for the service's refits and the daemon's measurement jobs) and back (for the
// stored fit's JSON).

#include <string>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::records {

// The model whose parameters a stored fit keeps (the paper's five): the one the service fits.
inline constexpr ModelKind kStoredModel = ModelKind::paper;

// The software a stored fit names as its model_version: "skinspec <version>".
std::string model_version();

// `result` as the store keeps it: the options it was fitted with ({"site", "lateral_diffusion"}),
// model_version() and the digest of the optical tables behind the fitter. The caller sets
// measurement_id (record_measurement does it for a fit stored with its measurement).
store::Fit to_store_fit(const FitResult& result, const FitOptions& options, const std::string& tables_digest);

// A stored fit's values as the fitter gave them.
FitResult to_fit_result(const store::Fit& fit);

}  // namespace skinspec::records
