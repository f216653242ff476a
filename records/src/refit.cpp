#include "skinspec/records/refit.hpp"

#include <fmt/format.h>

#include <chrono>
#include <future>
#include <map>

#include "skinspec/records/fit_record.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::records {

namespace {

// Large enough that a transaction's commit is a small share of a batch's time, small enough
// that a stop is prompt and little work is lost to a kill.
constexpr int kBatch = 512;
constexpr std::size_t kFailuresKept = 10;

using Clock = std::chrono::steady_clock;

// One measurement's fit, or why the fitter refused it.
struct Refitted {
  std::optional<store::Fit> fit;
  std::string failure;
};

// Nothing may leave a worker thread: whatever is thrown refuses this measurement.
Refitted refit_one(const Fitter& fitter, const store::Measurement& m, const FitOptions& options) {
  try {
    auto fit = fitted(fitter, m.reflectance, options);
    if (!fit) return {std::nullopt, fmt::format("measurement {}: {}", m.id, fit.error())};
    fit->measurement_id = m.id;
    return {std::move(*fit), {}};
  } catch (const std::exception& e) {
    return {std::nullopt, fmt::format("measurement {}: {}", m.id, e.what())};
  }
}

class Refit {
 public:
  Refit(store::Store& store, const Fitter& fitter, const RefitRequest& request)
      : store_(store), fitter_(fitter), request_(request) {}

  // Three things at once: batch n is stored on a thread of its own while batch n + 1 is fitted
  // on threads of lower priority and batch n + 2 read on this one. The fitting is what takes
  // longest; storing and reading, which it would wait for, go first.
  std::expected<RefitReport, store::StoreError> run(const RefitObserver& observer) {
    store::RefitQuery query{current_fit_maker(fitter_, request_.model), request_.session_id, 0, kBatch};
    // Counted while the first batch is read and fitted: the count reads about as much as all
    // the batches together, and done first it left a core idle for 0.2-0.3 s of a refit of
    // 100,000.
    auto counting = std::async(std::launch::async, [this, query] { return store_.count_measurements_to_refit(query); });
    std::future<StoreOutcome> storing;
    // The batch being stored counted once it is: the observer hears, and may stop the refit.
    const auto settle = [&]() -> std::expected<bool, store::StoreError> {
      if (counting.valid()) {
        auto total = counting.get();
        if (!total) return std::unexpected(total.error());
        report_.progress.total = *total;
      }
      if (!storing.valid()) return true;
      auto outcome = storing.get();
      if (!outcome) return std::unexpected(outcome.error());
      report_.progress.done += *outcome;
      return !observer || observer(progress_now());
    };
    auto batch = store_.measurements_to_refit(query);
    for (;;) {
      if (!batch) {
        (void)settle();
        return std::unexpected(batch.error());
      }
      if (batch->empty()) break;
      query.after_id = batch->back().id;
      // Read while this batch is fitted; an error, not an end, should that not happen.
      Batch next = std::unexpected(store::StoreError{store::StoreError::Kind::internal, "the next batch was not read"});
      auto fits = fit_batch(*batch, [&] { next = store_.measurements_to_refit(query); });
      if (!fits) {
        (void)settle();
        return std::unexpected(fits.error());
      }
      auto go_on = settle();
      if (!go_on) return std::unexpected(go_on.error());
      if (!*go_on) {
        report_.stopped = true;
        return report_;
      }
      storing = std::async(std::launch::async, [this, fits = std::move(*fits)]() -> StoreOutcome {
        if (fits.empty()) return 0;
        auto stored = store_.add_fits(fits);
        if (!stored) return std::unexpected(stored.error());
        return static_cast<std::int64_t>(fits.size());
      });
      batch = std::move(next);
    }
    auto go_on = settle();
    if (!go_on) return std::unexpected(go_on.error());
    report_.stopped = !*go_on;
    return report_;
  }

 private:
  using StoreOutcome = std::expected<std::int64_t, store::StoreError>;  // fits stored

  using Batch = std::expected<std::vector<store::Measurement>, store::StoreError>;

  // The batch's fits, while `meanwhile` runs on this thread; the measurements the fitter refused
  // counted and named in the report.
  template <typename Meanwhile>
  std::expected<std::vector<store::Fit>, store::StoreError> fit_batch(const std::vector<store::Measurement>& batch,
                                                                      Meanwhile meanwhile) {
    std::vector<FitOptions> options;
    for (const auto& m : batch) {
      auto o = options_for(m.session_id);
      if (!o) return std::unexpected(o.error());
      options.push_back(*o);
    }
    std::vector<Refitted> refitted(batch.size());
    parallel_for_in_background(
        batch.size(), 0, [&](std::size_t i) { refitted[i] = refit_one(fitter_, batch[i], options[i]); }, meanwhile);
    std::vector<store::Fit> fits;
    for (auto& r : refitted) {
      if (r.fit) {
        fits.push_back(std::move(*r.fit));
      } else {
        ++report_.progress.failed;
        if (report_.failures.size() < kFailuresKept) report_.failures.push_back(std::move(r.failure));
      }
    }
    return fits;
  }

  // A measurement is fitted with its session's site.
  std::expected<FitOptions, store::StoreError> options_for(store::Id session_id) {
    auto known = sites_.find(session_id);
    if (known == sites_.end()) {
      auto session = store_.session(session_id);
      if (!session) return std::unexpected(session.error());
      known = sites_.emplace(session_id, session->site).first;
    }
    FitOptions options;
    options.model = request_.model;
    options.site = known->second;
    options.lateral_diffusion = request_.lateral_diffusion;
    return options;
  }

  RefitProgress progress_now() {
    auto& p = report_.progress;
    p.elapsed_s = std::chrono::duration<double>(Clock::now() - started_).count();
    const auto handled = p.done + p.failed;
    if (handled > 0 && p.elapsed_s > 0)
      p.remaining_s = static_cast<double>(std::max<std::int64_t>(p.total - handled, 0)) * p.elapsed_s /
                      static_cast<double>(handled);
    return p;
  }

  store::Store& store_;
  const Fitter& fitter_;
  RefitRequest request_;
  RefitReport report_;
  std::map<store::Id, std::string> sites_;
  Clock::time_point started_ = Clock::now();
};

}  // namespace

store::FitMaker current_fit_maker(const Fitter& fitter, ModelKind model) {
  const auto& optics = fitter.optics(model);
  return {std::string(to_string(model)), model_version(), optics.tables_digest(), optics.constants_digest()};
}

std::expected<RefitReport, store::StoreError> refit(store::Store& store, const Fitter& fitter,
                                                    const RefitRequest& request, const RefitObserver& observer) {
  return Refit(store, fitter, request).run(observer);
}

}  // namespace skinspec::records
