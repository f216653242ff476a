#include "skinspec/records/import_file.hpp"

#include <fmt/format.h>

#include <atomic>
#include <condition_variable>
#include <thread>
#include <mutex>
#include <nlohmann/json.hpp>

#include "skinspec/records/fit_record.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::records {

namespace {

// How often, in spectra, the observer hears of the fitting.
constexpr std::size_t kReportEvery = 256;

std::unexpected<ImportFailure> bad_file(std::string_view source, std::size_t line, std::string message) {
  return std::unexpected(ImportFailure{InputError{std::string(source), line, 0, std::move(message)}});
}

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
        ready_(spectra.size()) {}
  ~FittedRows() {
    stop_ = true;  // a taker that gave up leaves nothing for the fitting to do
    if (fitting_.joinable()) fitting_.join();
  }

  template <typename MakeMeasurement>
  void start(MakeMeasurement make) {
    fitting_ =
        std::thread([this, make] { parallel_for(spectra_.size(), 0, [&](std::size_t i) { fit_one(i, make); }); });
  }

  // The next row in the file's order, once fitted; null after the last. The row taken before is
  // stored by then, and let go: a large file is not held twice over.
  const Row* next() {
    if (taken_ > 0) rows_[taken_ - 1] = Row{};
    if (taken_ == rows_.size()) return nullptr;
    std::unique_lock lock(mutex_);
    ready_changed_.wait(lock, [&] { return ready_[taken_] || stop_; });
    if (stop_) throw Stopped{};
    const std::size_t i = taken_++;
    if (!refused_[i].empty()) throw Refused{i, refused_[i]};
    return &rows_[i];
  }

 private:
  template <typename MakeMeasurement>
  void fit_one(std::size_t i, const MakeMeasurement& make) {
    if (stop_) return;
    // Nothing may leave a worker thread: whatever is thrown refuses this spectrum, by its line.
    try {
      rows_[i].first = make(spectra_[i]);
      auto fit = fitted(fitter_, spectra_[i].reflectance, options_);
      if (fit) rows_[i].second = std::move(*fit);
      else refused_[i] = fit.error();
    } catch (const std::exception& e) {
      refused_[i] = e.what();
    }
    std::lock_guard lock(mutex_);
    ready_[i] = true;
    ++fitted_count_;
    if (observer_ && (fitted_count_ % kReportEvery == 0 || fitted_count_ == rows_.size()) &&
        !observer_(fitted_count_, rows_.size()))
      stop_ = true;
    ready_changed_.notify_all();
  }

  const Fitter& fitter_;
  const std::vector<ImportedSpectrum>& spectra_;
  const FitOptions& options_;
  const ImportObserver& observer_;
  std::vector<Row> rows_;
  std::vector<std::string> refused_;  // why, for each spectrum the fitter refused
  std::mutex mutex_;
  std::condition_variable ready_changed_;
  std::vector<bool> ready_;  // guarded by mutex_, as are the two below
  std::size_t fitted_count_ = 0;
  std::atomic<bool> stop_{false};
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

std::string import_job_result(std::size_t imported, std::string_view source, ImportFormat format) {
  return nlohmann::json{{"imported", imported}, {"source", source}, {"format", to_string(format)}}.dump(
      -1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::expected<ImportedFile, ImportFailure> import_file(store::Store& store, const Fitter& fitter, store::Id session_id,
                                                       std::string_view bytes, std::string_view source,
                                                       ImportFormat format, const ImportObserver& observer,
                                                       std::optional<store::Id> job_id) {
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
  auto spectra = read_import(bytes, source, format);
  if (!spectra) return std::unexpected(ImportFailure{spectra.error()});
  if (observer && !observer(0, spectra->size())) return ImportedFile{{}, true};

  const FitOptions options{
      .model = *model, .site = session->site, .lateral_diffusion = true, .weights = {}, .held = {}};
  const auto now = store::Time(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()));
  FittedRows rows(fitter, *spectra, options, observer);
  rows.start([&](const ImportedSpectrum& s) { return imported_measurement(s, session_id, source, format, now); });
  std::optional<store::JobCompletion> completion;
  if (job_id) completion = store::JobCompletion{*job_id, import_job_result(spectra->size(), source, format)};
  try {
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
