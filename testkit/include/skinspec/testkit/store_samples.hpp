#pragma once
// Test helpers for the store: a scratch directory, records filled with values derived from a
// number (so that a test can tell what a stored row must hold), whole-file reads, and direct
// SQLite queries that bypass the store.

#include <filesystem>
#include <stdexcept>
#include <string>

#include "skinspec/store/store.hpp"

namespace skinspec::testing {

// The value of a store call that must succeed; its error, thrown, fails the test otherwise.
template <typename T>
T value_of(store::Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

// A fresh directory under the system's temporary directory, removed with everything in it.
class ScratchDirectory {
 public:
  ScratchDirectory();
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// The native PR-650 grid, 380-780 nm by 4 nm (101 points).
std::vector<double> native_grid();

store::WhiteStandard sample_white_standard(int n);
store::Instrument sample_instrument(int n);
store::Session sample_session(int n);
// A sample measurement of `session_id` whose every value follows from `n`: the label is
// "sample <n>"; radiance, its standard deviation, reflectance and raw reply are functions of n.
store::Measurement sample_measurement(store::Id session_id, int n);
// A fit whose values follow from `n`, with an undetermined (infinite) bilirubin error.
store::Fit sample_fit(int n);

// `size` bytes of a map's data that follow from `seed`: the first half random (which deflating
// cannot shrink), the rest a slowly changing series of floats (which it shrinks much).
std::string sample_map_bytes(std::int64_t size, unsigned seed);
// `bytes` as a map's data, read from memory; each read's offset is added to `offsets` when given.
store::MapData map_data_of(const std::string& bytes, std::vector<std::int64_t>* offsets = nullptr);
// A new job of `kind` (of `session` when given), running: as a job is when it ends with what it made.
store::Id running_job(store::Store& store, const std::string& kind, std::optional<store::Id> session = std::nullopt);
// A map of `session` named `name`, with `bytes` as its data, the summary {"pixels":12}, the
// header "ENVI\n" and pictures of melanin and bilirubin, stored with the end of a job of its own.
store::Id store_sample_map(store::Store& store, std::optional<store::Id> session, const std::string& name,
                           const std::string& bytes);

// Whether `stored` holds exactly what sample_measurement(session, n) / sample_fit(n) gave, for
// the n in its label; an explanation when not.
std::string check_sample_measurement(const store::Measurement& stored);
std::string check_sample_fit(const store::Fit& stored, int n);

std::string file_bytes(const std::string& path);

// Direct queries on a database file, read-only, outside the store.
std::string sqlite_text(const std::string& path, const std::string& sql);
long long sqlite_integer(const std::string& path, const std::string& sql);
// Runs statements read-write (for building test databases by hand).
void sqlite_execute(const std::string& path, const std::string& sql);

}  // namespace skinspec::testing
