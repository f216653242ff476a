#pragma once
// Stored measurements fitted again with the current model and constants: the new fits are
// stored beside the old, each naming the model, the software and the digests of the tables
// and constants that made it (store::FitMaker). A measurement that already holds a fit by the
// same maker is done, so a refit stopped anywhere (cancelled, killed) and run again refits
// every measurement exactly once: none twice, none skipped.

#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::records {

struct RefitRequest {
  ModelKind model = kDefaultModel;
  std::optional<store::Id> session_id{};  // every session's measurements when empty
  bool lateral_diffusion = true;
};

struct RefitProgress {
  std::int64_t total = 0;   // measurements to refit when the run began
  std::int64_t done = 0;    // refitted and stored by this run
  std::int64_t failed = 0;  // whose spectrum the fitter refused: nothing stored, tried again next run
  double elapsed_s = 0;
  std::optional<double> remaining_s{};  // at the rate so far, once there is one
};

// Told after each batch is stored, in order; returning false stops the refit there. What is
// stored stays, and so does the batch being stored then, if any (not told of, but counted in
// the report); batches fitted and waiting to be stored are dropped, for the next run.
using RefitObserver = std::function<bool(const RefitProgress&)>;

struct RefitReport {
  RefitProgress progress;
  bool stopped = false;               // the observer asked to stop
  std::vector<std::string> failures;  // the first few refusals: "measurement 12: ..."
};

// The maker of the fits `model` makes now.
store::FitMaker current_fit_maker(const Fitter& fitter, ModelKind model);

// Each measurement to refit is fitted with its session's site, a batch at a time on every core,
// and each batch's fits are stored in one transaction.
std::expected<RefitReport, store::StoreError> refit(store::Store& store, const Fitter& fitter,
                                                    const RefitRequest& request, const RefitObserver& observer);

}  // namespace skinspec::records
