#include "skinspec/records/refit.hpp"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <future>
#include <map>
#include <optional>
#include <utility>

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
  // longest; storing and reading, which it would wait for, go first. Fitted batches may queue
  // for storing (kBatchesStoring), so that a store slowed for a while does not stop the
  // fitting.
  std::expected<RefitReport, store::StoreError> run(const RefitObserver& observer) {
    store::RefitQuery query{current_fit_maker(fitter_, request_.model), request_.session_id, 0, kBatch};
    // Counted while the first batch is read and fitted: the count reads about as much as all
    // the batches together, and done first it left a core idle for 0.2-0.3 s of a refit of
    // 100,000.
    counting_ = std::async(std::launch::async, [this, query] { return store_.count_measurements_to_refit(query); });
    auto batch = store_.measurements_to_refit(query);
    for (;;) {
      if (!batch) return finish(batch.error());
      if (batch->empty()) break;
      query.after_id = batch->back().id;
      // Read while this batch is fitted; an error, not an end, should that not happen.
      Batch next = std::unexpected(store::StoreError{store::StoreError::Kind::internal, "the next batch was not read"});
      auto fits = fit_batch(*batch, [&] { next = store_.measurements_to_refit(query); });
      if (!fits) return finish(fits.error());
      auto go_on = settle(observer, kBatchesStoring - 1);
      if (!go_on) return finish(go_on.error());
      if (!*go_on) {
        report_.stopped = true;
        return finish(std::nullopt);
      }
      store_after_the_others(std::move(*fits));
      batch = std::move(next);
    }
    auto go_on = settle(observer, 0);
    if (!go_on) return finish(go_on.error());
    report_.stopped = !*go_on;
    return finish(std::nullopt);
  }

 private:
  using StoreOutcome = std::expected<std::int64_t, store::StoreError>;  // fits stored
  using Batch = std::expected<std::vector<store::Measurement>, store::StoreError>;

  // At most this many batches handed to storing and not yet counted: 8,192 fits, about 40 MB
  // (beside the batch being fitted and those being read), some 0.7 s of fitting on 2 cores. A commit can be held up
  // about that long by the disk (by the file being synced after the log of an import of 100,000 was copied into it);
  // with room for only one batch behind it, the fitting stopped that long.
  static constexpr std::size_t kBatchesStoring = 16;

  // Stores `fits` on a thread of its own once the batch handed before has been, and not at all
  // if that one failed: the batches commit in order. The task lets go of the batch before and
  // of its own fits when it ends, or each would hold every batch before it until the last.
  void store_after_the_others(std::vector<store::Fit> fits) {
    std::shared_future<StoreOutcome> before = storing_.empty() ? std::shared_future<StoreOutcome>{} : storing_.back();
    storing_.push_back(
        std::async(std::launch::async, [this, before = std::move(before), fits = std::move(fits)]() mutable {
          return store_in_turn(std::exchange(before, {}), std::exchange(fits, {}));
        }).share());
  }

  StoreOutcome store_in_turn(std::shared_future<StoreOutcome> before, std::vector<store::Fit> fits) {
    if (before.valid() && !before.get())
      return std::unexpected(store::StoreError{store::StoreError::Kind::internal, "an earlier batch was not stored"});
    // A refit that ends early stores no more than the batch under way: those waiting are
    // fitted again by the next run.
    if (fits.empty() || ending_) return 0;
    auto stored = store_.add_fits(fits);
    if (!stored) return std::unexpected(stored.error());
    return static_cast<std::int64_t>(fits.size());
  }

  // Counts the batches stored so far, oldest first, waiting for the oldest while more than
  // `left` are in hand (and for the count, the first time): the observer hears of each, and
  // may stop the refit.
  std::expected<bool, store::StoreError> settle(const RefitObserver& observer, std::size_t left) {
    if (counting_.valid()) {
      auto total = counting_.get();
      if (!total) return std::unexpected(total.error());
      report_.progress.total = *total;
    }
    while (!storing_.empty() && (storing_.size() > left || is_ready(storing_.front()))) {
      const auto outcome = take_oldest();
      if (!outcome) return std::unexpected(outcome.error());
      if (observer && !observer(progress_now())) return false;
    }
    return true;
  }

  // The report, or the first error, once the batch being stored, if any, is stored and
  // counted (and those waiting dropped): however a refit ends, it ends promptly, leaves nothing
  // running, reports all it stored, and does not keep quiet about a batch that failed after it
  // was asked to stop.
  std::expected<RefitReport, store::StoreError> finish(std::optional<store::StoreError> error) {
    ending_ = true;
    while (!storing_.empty()) {
      auto outcome = take_oldest();
      if (!outcome && !error) error = std::move(outcome.error());
    }
    if (counting_.valid()) counting_.wait();
    if (error) return std::unexpected(std::move(*error));
    return report_;
  }

  StoreOutcome take_oldest() {
    StoreOutcome outcome = storing_.front().get();
    storing_.pop_front();
    if (outcome) report_.progress.done += *outcome;
    return outcome;
  }

  static bool is_ready(const std::shared_future<StoreOutcome>& f) {
    return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }

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
  std::future<std::expected<std::int64_t, store::StoreError>> counting_;
  std::deque<std::shared_future<StoreOutcome>> storing_;  // oldest first
  std::atomic<bool> ending_{false};
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
