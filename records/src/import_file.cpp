#include "skinspec/records/import_file.hpp"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <nlohmann/json.hpp>

#include "skinspec/records/fit_record.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::records {

namespace {

// A file's scale in JSON: null for CGATS, whose SPECTRAL_NORM gives it.
nlohmann::json scale_json(std::optional<ReflectanceScale> scale) {
  return scale ? nlohmann::json(to_string(*scale)) : nlohmann::json();
}

// How often, in spectra, the observer hears of the fitting.
constexpr std::size_t kReportEvery = 256;

std::unexpected<ImportFailure> bad_file(std::string_view source, std::size_t line, std::string message) {
  return std::unexpected(ImportFailure{InputError{std::string(source), line, 0, std::move(message)}});
}

// What storing a spectrum with its fit is taken to cost, to decide when an import starts storing
// (FittedRows::wait_until_worth_storing): about what a spectrum of 101 samples costs on a
// 2-core machine. A guess: too low, and storing starts late and the import takes a little
// longer; too high, and the writer is held a little longer than storing needs.
constexpr double kStoreSecondsPerRow = 100e-6;

// The file's spectra fitted on every core by a thread of its own while the store takes them,
// in the file's order, as they become ready: storing overlaps fitting. A spectrum the fitter
// refuses, or the observer's stop, ends the taking by an exception, so that the store's
// transaction stores nothing.
class FittedRows {
 public:
  using Row = std::pair<store::Measurement, std::optional<store::Fit>>;
  struct Stopped {};
  struct Refused {
    std::size_t index;
    std::string why;
  };

  FittedRows(const Fitter& fitter, const std::vector<ImportedSpectrum>& spectra, const FitOptions& options,
             const ImportObserver& observer)
      : fitter_(fitter),
        spectra_(spectra),
        options_(options),
        observer_(observer),
        rows_(spectra.size()),
        refused_(spectra.size()),
        ready_(spectra.size()),
        first_refused_(spectra.size()) {}
  ~FittedRows() {
    stop_ = true;  // a taker that gave up leaves nothing for the fitting to do
    if (fitting_.joinable()) fitting_.join();
  }

  template <typename MakeMeasurement>
  void start(MakeMeasurement make) {
    started_ = std::chrono::steady_clock::now();
    fitting_ = std::thread([this, make] {
      // Nothing may leave this thread (a thread the fitting could not start, say): the taker
      // rethrows it instead.
      try {
        parallel_for_in_background(spectra_.size(), 0, [&](std::size_t i) { fit_one(i, make); });
      } catch (...) {
        std::lock_guard lock(mutex_);
        failure_ = std::current_exception();
      }
      ready_changed_.notify_all();
    });
  }

  // Waits until storing every row from now on would end no sooner than the fitting, at the
  // rate the fitting has gone so far: the store's writer, which every other write of the
  // service waits for, is then held about as long as storing takes, however slow the fitting.
  // Throws as next() does.
  void wait_until_worth_storing() {
    const double storing_s = kStoreSecondsPerRow * static_cast<double>(rows_.size());
    std::unique_lock lock(mutex_);
    ready_changed_.wait(lock, [&] {
      if (ended() || fitted_count_ == rows_.size()) return true;
      if (fitted_count_ == 0) return false;
      const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
      const double fitting_left_s =
          elapsed_s * static_cast<double>(rows_.size() - fitted_count_) / static_cast<double>(fitted_count_);
      return fitting_left_s <= storing_s;
    });
    throw_if_ended();
  }

  // The next row in the file's order, once fitted; null after the last. The row taken before is
  // stored by then, and let go: a large file is not held twice over.
  const Row* next() {
    if (taken_ > 0) rows_[taken_ - 1] = Row{};
    // Storing goes on after the last fit: the observer still hears, and may stop it until the
    // last row is stored.
    if (observer_ && (taken_ % kReportEvery == 0 || taken_ == rows_.size())) hear(fitted_so_far());
    std::unique_lock lock(mutex_);
    if (taken_ == rows_.size()) {
      if (stop_) throw Stopped{};
      return nullptr;
    }
    ready_changed_.wait(lock, [&] { return ready_count_ > taken_ || ended(); });
    throw_if_ended();
    return &rows_[taken_++];
  }

 private:
  template <typename MakeMeasurement>
  void fit_one(std::size_t i, const MakeMeasurement& make) {
    // Past a refused spectrum nothing will be stored.
    if (stop_ || i > first_refused_) return;
    // Nothing may leave a worker thread: whatever is thrown refuses this spectrum, by its line.
    try {
      rows_[i].first = make(spectra_[i]);
      auto fit = fitted(fitter_, spectra_[i].reflectance, options_);
      if (fit) rows_[i].second = std::move(*fit);
      else refused_[i] = fit.error();
    } catch (const std::exception& e) {
      refused_[i] = e.what();
    } catch (...) {
      refused_[i] = "an unexpected error";
    }
    std::size_t done = 0;
    {
      std::lock_guard lock(mutex_);
      ready_[i] = true;
      while (ready_count_ < ready_.size() && ready_[ready_count_]) ++ready_count_;
      if (!refused_[i].empty() && i < first_refused_) first_refused_ = i;
      done = ++fitted_count_;
    }
    ready_changed_.notify_all();
    if (observer_ && (done % kReportEvery == 0 || done == rows_.size())) hear(done);
  }

  std::size_t fitted_so_far() {
    std::lock_guard lock(mutex_);
    return fitted_count_;
  }

  // A refused spectrum with every one before it fitted: the file's first refused spectrum.
  bool refusal_known() const { return first_refused_ < ready_count_; }

  // With mutex_ held: a stop, the fitting's failure or the file's first refused spectrum ends
  // the taking.
  bool ended() const { return stop_ || failure_ || refusal_known(); }
  void throw_if_ended() const {
    if (failure_) std::rethrow_exception(failure_);
    if (stop_) throw Stopped{};
    if (refusal_known()) throw Refused{first_refused_, refused_[first_refused_]};
  }

  // The observer, one call at a time; its stop, or its failure to hear, stops the import.
  void hear(std::size_t done) {
    std::lock_guard lock(observing_);
    bool go_on = false;
    try {
      go_on = observer_(done, rows_.size());
    } catch (...) {
      // nothing leaves the thread
    }
    if (go_on) return;
    {
      std::lock_guard ready_lock(mutex_);
      stop_ = true;
    }
    ready_changed_.notify_all();
  }

  const Fitter& fitter_;
  const std::vector<ImportedSpectrum>& spectra_;
  const FitOptions& options_;
  const ImportObserver& observer_;
  std::vector<Row> rows_;
  std::vector<std::string> refused_;  // why, for each spectrum the fitter refused
  std::mutex mutex_, observing_;
  std::condition_variable ready_changed_;
  std::vector<bool> ready_;      // guarded by mutex_, as are the three below
  std::size_t ready_count_ = 0;  // how many at the start of the file are ready
  std::size_t fitted_count_ = 0;
  std::atomic<std::size_t> first_refused_;  // the lowest index refused so far, or size() for none
  std::atomic<bool> stop_{false};
  std::exception_ptr failure_;  // what ended the fitting thread, guarded by mutex_
  std::chrono::steady_clock::time_point started_;
  std::size_t taken_ = 0;  // the taker's own
  std::thread fitting_;    // last: joined before the rest goes
};

}  // namespace

store::Measurement imported_measurement(const ImportedSpectrum& spectrum, store::Id session_id, std::string_view source,
                                        ImportFormat format, store::Time now) {
  store::Measurement m;
  m.session_id = session_id;
  m.kind = store::MeasurementKind::imported;
  m.label = spectrum.sample_id;
  m.quality = "imported";
  m.units = "reflectance";
  m.settings = nlohmann::json{{"source",
                               {{"file", source},
                                {"format", to_string(format)},
                                {"scale", scale_json(spectrum.scale)},
                                {"sample_id", spectrum.sample_id},
                                {"line", spectrum.line},
                                {"instrument", spectrum.instrument}}}}
                   .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  m.reading_count = 1;
  m.reflectance = spectrum.reflectance;
  m.started_at = now;
  m.finished_at = now;
  return m;
}

std::string ImportFailure::message() const {
  if (const auto* input = std::get_if<InputError>(&cause)) return input->what();
  return std::get<store::StoreError>(cause).message;
}

std::string import_job_result(std::size_t imported, std::string_view source, ImportFormat format,
                              std::optional<ReflectanceScale> scale) {
  return nlohmann::json{
      {"imported", imported}, {"source", source}, {"format", to_string(format)}, {"scale", scale_json(scale)}}
      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::expected<ImportedFile, ImportFailure> import_file(store::Store& store, const Fitter& fitter, store::Id session_id,
                                                       std::string_view bytes, std::string_view source,
                                                       ImportFormat format, const ImportObserver& observer,
                                                       std::optional<store::Id> job_id, ScaleRequest scale) {
  const auto session = store.session(session_id);
  if (!session) return std::unexpected(ImportFailure{session.error()});
  // Refused before the fitting, which a large file spends long on.
  if (session->state != store::SessionState::open)
    return std::unexpected(ImportFailure{
        store::StoreError{store::StoreError::Kind::conflict,
                          fmt::format("session {} is {}, not open", session_id, store::to_string(session->state)), 0}});
  const auto model = parse_model_kind(session->model);
  if (!model)
    return std::unexpected(ImportFailure{store::StoreError{
        store::StoreError::Kind::conflict,
        fmt::format("session {}'s model '{}' is not one this version knows", session_id, session->model), 0}});
  auto spectra = read_import(bytes, source, format, scale);
  if (!spectra) return std::unexpected(ImportFailure{spectra.error()});
  if (observer && !observer(0, spectra->size())) return ImportedFile{{}, true};

  const FitOptions options{
      .model = *model, .site = session->site, .lateral_diffusion = true, .weights = {}, .held = {}, .start = {}};
  const auto now = store::Time(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()));
  FittedRows rows(fitter, *spectra, options, observer);
  rows.start([&](const ImportedSpectrum& s) { return imported_measurement(s, session_id, source, format, now); });
  std::optional<store::JobCompletion> completion;
  if (job_id)
    completion =
        store::JobCompletion{*job_id, import_job_result(spectra->size(), source, format, spectra->front().scale)};
  try {
    rows.wait_until_worth_storing();
    auto stored = store.record_measurements_as_ready([&] { return rows.next(); }, completion);
    if (!stored) return std::unexpected(ImportFailure{stored.error()});
    return ImportedFile{std::move(*stored), false};
  } catch (const FittedRows::Stopped&) {
    return ImportedFile{{}, true};
  } catch (const FittedRows::Refused& refused) {
    const auto& s = (*spectra)[refused.index];
    return bad_file(source, s.line, fmt::format("spectrum '{}' cannot be fitted: {}", s.sample_id, refused.why));
  }
}

}  // namespace skinspec::records
