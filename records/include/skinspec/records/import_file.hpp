#pragma once
// One file of spectra imported into a session (docs/store.md, "Imports"): checked whole, then
// read (import.hpp, SpectrumStream), each spectrum fitted with the session's model and site on
// every core, and stored with its fit as it is ready, all of them or none
// (Store::record_measurements_as_ready). The import holds a bounded number of spectra whatever
// the file's size. A defect anywhere in the file, or a spectrum the fitter refuses, refuses the
// whole file, naming its line; nothing of it is stored.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/records/import.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::records {

// An imported spectrum as a measurement of `session_id` (kind imported, its reflectance, no
// radiance), its provenance in `settings`: {"source": {"file", "format", "scale" (how the
// values were read: fraction or percent; null for CGATS), "sample_id", "line", "instrument"}}.
store::Measurement imported_measurement(const ImportedSpectrum& spectrum, store::Id session_id, std::string_view source,
                                        ImportFormat format, store::Time now);

// Why a file was not imported: the file itself (bad input), or the store.
struct ImportFailure {
  std::variant<InputError, store::StoreError> cause;
  bool bad_file() const { return std::holds_alternative<InputError>(cause); }
  std::string message() const;  // "FILE:LINE:COLUMN: what", or the store's message
};

// Told how many of the file's spectra are fitted, of how many: once with none when the file has
// been read, then as the fitting and the storing go (from any thread, one call at a time); once
// all are fitted, every call tells fitted == total while the rest is stored. Returning false
// stops the import: nothing of the file is stored. It may write to the store: the import holds
// the store's writer only while a batch of the file is written, and never waits for the observer
// meanwhile.
using ImportObserver = std::function<bool(std::size_t fitted, std::size_t total)>;

struct ImportedFile {
  std::vector<store::RecordedMeasurement> stored;  // in the file's order
  bool stopped = false;                            // the observer stopped it: nothing stored
};

// With `job_id`, the running import job ends `succeeded` in the transaction that stores the
// file, its result {"imported": count, "source": file, "format": name, "scale": as read}
// (import_job_result). `scale` is how the file writes its values (read_import).
std::expected<ImportedFile, ImportFailure> import_file(store::Store& store, const Fitter& fitter, store::Id session_id,
                                                       std::string_view bytes, std::string_view source,
                                                       ImportFormat format, const ImportObserver& observer = {},
                                                       std::optional<store::Id> job_id = std::nullopt,
                                                       ScaleRequest scale = ScaleRequest::automatic);

// The same, the file read a piece at a time (bytes_of_file: a file of any size).
std::expected<ImportedFile, ImportFailure> import_file(store::Store& store, const Fitter& fitter, store::Id session_id,
                                                       const ReadBytes& bytes, std::string_view source,
                                                       ImportFormat format, const ImportObserver& observer = {},
                                                       std::optional<store::Id> job_id = std::nullopt,
                                                       ScaleRequest scale = ScaleRequest::automatic);

// The result an import job records: what it imported, from where, and how its values were read
// (null for CGATS).
std::string import_job_result(std::size_t imported, std::string_view source, ImportFormat format,
                              std::optional<ReflectanceScale> scale);

}  // namespace skinspec::records
