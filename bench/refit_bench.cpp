// A refit of a whole SQLite database (records::refit, as `skinspec refit` runs it): N stored
// measurements of skin-like reflectance, each with an older fit, fitted again with the default
// model on every core and stored 512 fits to a transaction. Prints the refit's rate and what
// 100,000 measurements would take at it; the goal is <= 10 s for 100,000 on 2 cores.
// Setting up stores the measurements one committed transaction each, as skinspecd would.
// Run: build/release/bin/refit_bench [N]   (default 20000; the file goes to $TMPDIR or /tmp)

#include <fmt/format.h>
#include <stdlib.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "fitter_loader.hpp"
#include "skinspec/fit/model.hpp"
#include "skinspec/records/refit.hpp"

namespace {

using namespace skinspec;

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "refit_bench: %s\n", message.c_str());
  std::exit(1);
}

std::filesystem::path temporary_directory() {
  std::string pattern = (std::filesystem::temp_directory_path() / "skinspec-refit-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) die("cannot make a temporary directory");
  return pattern;
}

void fill(store::Store& db, const Fitter& fitter, int count) {
  const auto grid = Spectrum::uniform_grid(380, 780, 4);
  const auto& optics = fitter.optics(ModelKind::extended);
  const SkinModel model(optics, *optics.site("forearm"), grid, true);
  std::mt19937 random(42);
  std::uniform_real_distribution<double> melanin(1, 30), blood(1, 8), share(0.5, 0.95), bilirubin(0, 3);
  std::normal_distribution<double> noise(0, 0.002);
  store::Session session;
  session.subject = "S-1";
  session.site = "forearm";
  session.model = "extended";
  const auto id = db.create_session(session);
  if (!id) die(id.error().message);
  for (int n = 0; n < count; ++n) {
    Params p = default_params(ModelKind::extended);
    p[kMelanin] = melanin(random);
    p[kTotalHemoglobin] = blood(random);
    p[kOxygenSaturation] = share(random);
    p[kBilirubin] = bilirubin(random);
    auto r = model.reflectance(p);
    for (double& v : r) v += noise(random);
    store::Measurement m;
    m.session_id = *id;
    m.label = "sample";
    m.quality = "OK";
    m.units = "W/(sr m2 nm)";
    m.settings = "{}";
    m.reading_count = 1;
    m.radiance = {grid, r};
    m.reflectance = {grid, r};
    store::Fit older;
    older.site = "forearm";
    older.model = "extended";
    older.params = {{"melanin", p[kMelanin], 0.1}};
    older.assessment = "{}";
    older.options = "{}";
    older.model_version = "skinspec 0.0.1";
    older.tables_digest = "older";
    older.constants_digest = "older";
    older.wavelength_nm = grid;
    older.measured = r;
    older.fitted = r;
    if (auto stored = db.record_measurement(m, older); !stored) die(stored.error().message);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int count = argc > 1 ? std::atoi(argv[1]) : 20000;
  if (count < 1) die("N must be a positive number of measurements");
  auto fitter = load_fitter();
  if (!fitter) die(fitter.error() + " (set SKINSPEC_DATA_DIR)");
  const auto dir = temporary_directory();
  {
    auto db = store::Store::open((dir / "lab.db").string());
    if (!db) die(db.error().message);
    const auto filling = std::chrono::steady_clock::now();
    fill(*db, *fitter, count);
    std::printf("stored %d measurements in %.1f s\n", count,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - filling).count());
    const auto started = std::chrono::steady_clock::now();
    const auto report = records::refit(*db, *fitter, {}, {});
    if (!report) die(report.error().message);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::printf("refitted %lld of %lld (%lld refused) in %.2f s: %.0f measurements/s; 100,000 would take %.1f s\n",
                static_cast<long long>(report->progress.done), static_cast<long long>(report->progress.total),
                static_cast<long long>(report->progress.failed), seconds, report->progress.done / seconds,
                100000.0 * seconds / static_cast<double>(report->progress.done));
  }
  std::filesystem::remove_all(dir);
  return 0;
}
