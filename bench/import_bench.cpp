// A lab's archive, imported and refitted (issue goals on 2 cores: 100,000 spectra imported with
// their fits in <= 15 s, refitted in <= 10 s; the log below twice the database and the memory
// below 200 MB at any size). N skin-like reflectances with noise (101 points, 380-780 nm) are
// written as one CSV file of one row per spectrum, imported from that file into a session of a
// new SQLite database as `records::import_file` does (read a piece at a time, fitted on every
// core, stored a batch at a time and published at the end), then refitted as `skinspec refit`
// does (`records::refit`, 512 fits to a transaction): once with the default model after one of
// its constants changed, once with the paper's model. Prints each phase's time and rate, the
// write-ahead log's longest length during the import, and the process's peak memory.
// Run: build/release/bin/import_bench [N [import-only]]   (default 100000; the file and the
// database go to $TMPDIR or /tmp; `import-only` leaves the refits out)

#include <fmt/format.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "fitter_loader.hpp"
#include "skinspec/fit/model.hpp"
#include "skinspec/records/import_file.hpp"
#include "skinspec/records/refit.hpp"

namespace {

using namespace skinspec;
using Clock = std::chrono::steady_clock;

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "import_bench: %s\n", message.c_str());
  std::exit(1);
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The process's processor time so far, user and system: while only one thread works, that
// thread's cost whatever else runs on the machine.
double cpu_seconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// One row per spectrum: "id,380nm,384nm,...", values as reflectance 0-1, written to `path` a row
// at a time (a million spectra are most of a GB).
void write_archive(const Fitter& fitter, int count, const std::filesystem::path& path) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (!file) die("cannot write " + path.string());
  const auto grid = Spectrum::uniform_grid(380, 780, 4);
  const auto& optics = fitter.optics(ModelKind::extended);
  const SkinModel model(optics, *optics.site("forearm"), grid, true);
  std::mt19937 random(42);
  std::uniform_real_distribution<double> melanin(1, 30), blood(1, 8), share(0.5, 0.95), bilirubin(0, 3);
  std::normal_distribution<double> noise(0, 0.002);
  std::string out = "id";
  for (const double w : grid) out += fmt::format(",{}nm", w);
  out += '\n';
  for (int n = 0; n < count; ++n) {
    Params p = default_params(ModelKind::extended);
    p[kMelanin] = melanin(random);
    p[kTotalHemoglobin] = blood(random);
    p[kOxygenSaturation] = share(random);
    p[kBilirubin] = bilirubin(random);
    out += fmt::format("S-{}", n);
    for (const double r : model.reflectance(p)) out += fmt::format(",{:.5f}", r + noise(random));
    out += '\n';
    if (std::fwrite(out.data(), 1, out.size(), file) != out.size()) die("cannot write " + path.string());
    out.clear();
  }
  if (std::fclose(file) != 0) die("cannot write " + path.string());
}

}  // namespace

int main(int argc, char** argv) {
  const int count = argc > 1 ? std::atoi(argv[1]) : 100000;
  if (count < 1) die("N must be a positive number of spectra");
  const bool refits = argc < 3 || std::string(argv[2]) != "import-only";
  auto fitter = load_fitter();
  if (!fitter) die(fitter.error() + " (set SKINSPEC_DATA_DIR)");
  std::string pattern = (std::filesystem::temp_directory_path() / "skinspec-import-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) die("cannot make a temporary directory");
  const std::filesystem::path dir = pattern;
  const auto csv = dir / "archive.csv";
  write_archive(*fitter, count, csv);
  const auto bytes = records::bytes_of_file(csv.string());
  if (!bytes) die("cannot read " + csv.string() + ": " + bytes.error());
  {
    std::error_code ec;
    const auto size_of = [&](const char* name) {
      const auto size = std::filesystem::file_size(dir / name, ec);
      return ec ? 0.0 : static_cast<double>(size) / 1e6;
    };
    auto db = store::Store::open((dir / "lab.db").string());
    if (!db) die(db.error().message);
    store::Session session;
    session.subject = "archive";
    session.site = "forearm";
    session.model = "extended";
    const auto id = db->create_session(session);
    if (!id) die(id.error().message);

    auto started = Clock::now();
    const double started_cpu_s = cpu_seconds();
    // The observer hears once when the file has been read, then as the spectra are fitted and stored.
    double read_s = 0, read_cpu_s = 0, fitted_s = 0, fitted_cpu_s = 0, longest_log = 0, database_then = 0;
    const auto phases = [&](std::size_t fitted, std::size_t total) {
      if (const double log = size_of("lab.db-wal"); log > longest_log) {
        longest_log = log;
        database_then = size_of("lab.db");
      }
      if (fitted == 0) read_s = seconds_since(started), read_cpu_s = cpu_seconds() - started_cpu_s;
      if (fitted == total && fitted_s == 0) fitted_s = seconds_since(started), fitted_cpu_s = cpu_seconds();
      return true;
    };
    const auto imported =
        records::import_file(*db, *fitter, *id, *bytes, "archive.csv", records::ImportFormat::csv, phases);
    if (!imported) die(imported.error().message());
    double seconds = seconds_since(started);
    const double stored_cpu_s = cpu_seconds() - fitted_cpu_s;
    // Storing begins while the last spectra are fitted; what remains after the last fit is
    // storing alone, on one thread, so its processor time is the store's.
    std::printf(
        "imported %zu spectra (%.1f MB of CSV) with their fits in %.2f s: %.0f spectra/s "
        "(read in %.2f s, %.2f s of processor time; all fitted %.2f s later; the rest stored in %.2f s more, "
        "%.2f s of processor time)\n",
        imported->stored.size(), size_of("archive.csv"), seconds,
        static_cast<double>(imported->stored.size()) / seconds, read_s, read_cpu_s, fitted_s - read_s,
        seconds - fitted_s, stored_cpu_s);

    rusage usage{};
    ::getrusage(RUSAGE_SELF, &usage);
    // The log is copied into the file behind each batch, so it stays short however large the file.
    std::printf(
        "database %.1f MB, its write-ahead log %.1f MB (at most %.1f MB during the import, beside a database of "
        "%.1f MB then); the process's peak memory %.0f MB\n",
        size_of("lab.db"), size_of("lab.db-wal"), longest_log, database_then,
        static_cast<double>(usage.ru_maxrss) / 1024);

    // Refitted twice, each as a new maker of fits: the default model with one of its constants
    // retuned (a new constants digest), the refit a better model calls for; then the paper's
    // model, which these spectra were not made with.
    ModelConstants retuned = fitter->optics(ModelKind::extended).constants();
    retuned.epidermis_scattering_scale *= 1.01;
    const Fitter improved = fitter->with_optics(fitter->optics(ModelKind::extended).with_constants(retuned));
    using Refit = std::tuple<const Fitter*, ModelKind, const char*>;
    std::vector<Refit> passes;
    if (refits)
      passes = {Refit{&improved, ModelKind::extended, "the default model, a constant retuned"},
                Refit{&*fitter, ModelKind::paper, "the paper's model"}};
    for (const auto& [maker, model, name] : passes) {
      started = Clock::now();
      const double refit_started_cpu_s = cpu_seconds();
      const auto report =
          records::refit(*db, *maker, {.model = model, .session_id = {}, .lateral_diffusion = true}, {});
      if (!report) die(report.error().message);
      seconds = seconds_since(started);
      std::printf(
          "refitted with %s: %lld of %lld (%lld refused) in %.2f s: %.0f measurements/s (%.2f s of processor "
          "time)\n",
          name, static_cast<long long>(report->progress.done), static_cast<long long>(report->progress.total),
          static_cast<long long>(report->progress.failed), seconds,
          static_cast<double>(report->progress.done) / seconds, cpu_seconds() - refit_started_cpu_s);
    }
  }
  std::filesystem::remove_all(dir);
  return 0;
}
