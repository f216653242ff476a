#include "skinspec/records/import_file.hpp"

#include <fmt/format.h>

#include <atomic>
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
  std::vector<std::pair<store::Measurement, std::optional<store::Fit>>> rows(spectra->size());
  std::vector<std::string> refused(spectra->size());
  std::atomic<std::size_t> fitted_count{0};
  std::atomic<bool> stop{false};
  std::mutex observing;
  parallel_for(spectra->size(), 0, [&](std::size_t i) {
    if (stop) return;
    const auto& s = (*spectra)[i];
    // Nothing may leave a worker thread: whatever is thrown refuses this spectrum, by its line.
    try {
      rows[i].first = imported_measurement(s, session_id, source, format, now);
      auto fit = fitted(fitter, s.reflectance, options);
      if (fit) rows[i].second = std::move(*fit);
      else refused[i] = fit.error();
    } catch (const std::exception& e) {
      refused[i] = e.what();
    }
    const auto done = ++fitted_count;
    if (observer && (done % kReportEvery == 0 || done == rows.size())) {
      std::lock_guard lock(observing);
      try {
        if (!observer(done, rows.size())) stop = true;
      } catch (const std::exception&) {
        stop = true;  // an observer that cannot hear any more stops the import; nothing leaves the thread
      }
    }
  });
  if (stop) return ImportedFile{{}, true};
  for (std::size_t i = 0; i < refused.size(); ++i)
    if (!refused[i].empty())
      return bad_file(source, (*spectra)[i].line,
                      fmt::format("spectrum '{}' cannot be fitted: {}", (*spectra)[i].sample_id, refused[i]));
  std::optional<store::JobCompletion> completion;
  if (job_id) completion = store::JobCompletion{*job_id, import_job_result(rows.size(), source, format)};
  auto stored = store.record_measurements(rows, completion);
  if (!stored) return std::unexpected(ImportFailure{stored.error()});
  return ImportedFile{std::move(*stored), false};
}

}  // namespace skinspec::records
