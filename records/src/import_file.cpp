#include "skinspec/records/import_file.hpp"

#include <fmt/format.h>

#include <algorithm>
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

// How many spectra the fitting may run ahead of the storing: what an import holds in memory,
// whatever the file's size (a few KB each with its fit).
constexpr std::size_t kWindow = 2048;

// The file's spectra read in its order and fitted on every core by a thread of its own, while
// the store takes them in the same order as they become ready: storing overlaps fitting, and the
// fitting runs at most kWindow spectra ahead. A spectrum the fitter refuses, or that cannot be
// read, or the observer's stop, ends the taking by an exception, so that the store keeps nothing.
class FittedRows {
 public:
  using Row = std::pair<store::Measurement, std::optional<store::Fit>>;
  struct Stopped {};
  struct Refused {
    InputError why;
  };

  FittedRows(const Fitter& fitter, SpectrumStream& spectra, std::string_view source, const FitOptions& options,
             const ImportObserver& observer)
      : fitter_(fitter),
        spectra_(spectra),
        source_(source),
        options_(options),
        observer_(observer),
        total_(spectra.size()),
        slots_(std::max<std::size_t>(2, std::min(kWindow, total_))),
        first_refused_(total_) {}
  ~FittedRows() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;  // a taker that gave up leaves nothing for the fitting to do
    }
    changed_.notify_all();
    if (fitting_.joinable()) fitting_.join();
  }

  template <typename MakeMeasurement>
  void start(MakeMeasurement make) {
    fitting_ = std::thread([this, make] {
      // Nothing may leave this thread (a thread the fitting could not start, say): the taker
      // rethrows it instead.
      try {
        parallel_for_in_background(total_, 0, [&](std::size_t i) { fit_one(i, make); });
      } catch (...) {
        std::lock_guard lock(mutex_);
        failure_ = std::current_exception();
      }
      changed_.notify_all();
    });
  }

  // The next row in the file's order, once fitted; null after the last. The row taken before is
  // stored by then, and let go.
  const Row* next() {
    if (taken_ > 0) slot_of(taken_ - 1).row = Row{};
    // Storing goes on after the last fit: the observer still hears, and may stop it until the
    // last row is stored.
    if (observer_ && (taken_ % kReportEvery == 0 || taken_ == total_)) hear(fitted_so_far());
    std::unique_lock lock(mutex_);
    if (taken_ == total_) {
      if (stop_) throw Stopped{};
      return nullptr;
    }
    changed_.wait(lock, [&] { return ready_count_ > taken_ || ended(); });
    throw_if_ended();
    const Row* row = &slot_of(taken_++).row;
    lock.unlock();
    changed_.notify_all();  // the window moved on
    return row;
  }

 private:
  struct Slot {
    Row row;
    std::optional<InputError> refused;
    bool ready = false;
  };

  Slot& slot_of(std::size_t i) { return slots_[i % slots_.size()]; }

  template <typename MakeMeasurement>
  void fit_one(std::size_t i, const MakeMeasurement& make) {
    std::optional<ImportedSpectrum> spectrum;
    std::optional<InputError> refused;
    {
      // Read in the file's order, and only into a slot the taker has let go of (it keeps the
      // row it took last until it asks for the next).
      std::unique_lock lock(mutex_);
      changed_.wait(
          lock, [&] { return stop_ || i > first_refused_ || (read_count_ == i && i + 1 < taken_ + slots_.size()); });
      // Past a refused spectrum nothing will be stored.
      if (stop_ || i > first_refused_) return;
      auto read = spectra_.next();
      ++read_count_;
      if (read && *read) spectrum = std::move(**read);
      else
        refused =
            read ? InputError{std::string(source_), 0, 0, "the file changed while it was imported"} : read.error();
    }
    changed_.notify_all();
    auto& slot = slot_of(i);  // no other thread's until it is ready
    // Nothing may leave a worker thread: whatever is thrown refuses this spectrum, by its line.
    if (spectrum) {
      std::string why;
      try {
        slot.row.first = make(*spectrum);
        auto fit = fitted(fitter_, spectrum->reflectance, options_);
        if (fit) slot.row.second = std::move(*fit);
        else why = fit.error();
      } catch (const std::exception& e) {
        why = e.what();
      } catch (...) {
        why = "an unexpected error";
      }
      if (!why.empty())
        refused = InputError{std::string(source_), spectrum->line, 0,
                             fmt::format("spectrum '{}' cannot be fitted: {}", spectrum->sample_id, why)};
    }
    std::size_t done = 0;
    {
      std::lock_guard lock(mutex_);
      slot.refused = std::move(refused);
      slot.ready = true;
      if (slot.refused && i < first_refused_) first_refused_ = i;
      while (ready_count_ < read_count_ && slot_of(ready_count_).ready) {
        slot_of(ready_count_).ready = false;  // taken as ready once: the slot is used again
        ++ready_count_;
      }
      done = ++fitted_count_;
    }
    changed_.notify_all();
    if (observer_ && (done % kReportEvery == 0 || done == total_)) hear(done);
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
  void throw_if_ended() {
    if (failure_) std::rethrow_exception(failure_);
    if (stop_) throw Stopped{};
    if (refusal_known()) throw Refused{*slot_of(first_refused_).refused};
  }

  // The observer, one call at a time; its stop, or its failure to hear, stops the import.
  void hear(std::size_t done) {
    std::lock_guard lock(observing_);
    bool go_on = false;
    try {
      go_on = observer_(done, total_);
    } catch (...) {
      // nothing leaves the thread
    }
    if (go_on) return;
    {
      std::lock_guard ready_lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
  }

  const Fitter& fitter_;
  SpectrumStream& spectra_;  // read with mutex_ held
  std::string_view source_;
  const FitOptions& options_;
  const ImportObserver& observer_;
  const std::size_t total_;
  std::vector<Slot> slots_;  // spectrum i in slot i % size
  std::mutex mutex_, observing_;
  std::condition_variable changed_;
  std::size_t read_count_ = 0;   // guarded by mutex_, as are the five below
  std::size_t ready_count_ = 0;  // how many at the start of the file are ready
  std::size_t fitted_count_ = 0;
  std::size_t first_refused_;  // the lowest index refused so far, or total_ for none
  bool stop_ = false;
  std::exception_ptr failure_;  // what ended the fitting thread
  std::size_t taken_ = 0;       // written by the taker with mutex_ held
  std::thread fitting_;         // last: joined before the rest goes
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
  return import_file(store, fitter, session_id, bytes_in_memory(bytes), source, format, observer, job_id, scale);
}

std::expected<ImportedFile, ImportFailure> import_file(store::Store& store, const Fitter& fitter, store::Id session_id,
                                                       const ReadBytes& bytes, std::string_view source,
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
  auto spectra = stream_import(bytes, source, format, scale);
  if (!spectra) return std::unexpected(ImportFailure{spectra.error()});
  const std::size_t total = (*spectra)->size();
  if (observer && !observer(0, total)) return ImportedFile{{}, true};

  const FitOptions options{
      .model = *model, .site = session->site, .lateral_diffusion = true, .weights = {}, .held = {}, .start = {}};
  const auto now = store::Time(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()));
  FittedRows rows(fitter, **spectra, source, options, observer);
  rows.start([&](const ImportedSpectrum& s) { return imported_measurement(s, session_id, source, format, now); });
  std::optional<store::JobCompletion> completion;
  if (job_id) completion = store::JobCompletion{*job_id, import_job_result(total, source, format, (*spectra)->scale())};
  try {
    auto stored = store.record_measurements_as_ready([&] { return rows.next(); }, completion);
    if (!stored) return std::unexpected(ImportFailure{stored.error()});
    return ImportedFile{std::move(*stored), false};
  } catch (const FittedRows::Stopped&) {
    return ImportedFile{{}, true};
  } catch (const FittedRows::Refused& refused) {
    return std::unexpected(ImportFailure{refused.why});
  }
}

}  // namespace skinspec::records
