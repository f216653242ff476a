// `skinspec import` against a real skinspecd: files sent over HTTP as import jobs, a new session
// opened for them, progress on stderr, a bad file reported by file and line with exit 2 while
// the good ones are stored, a file larger than the JSON body limit accepted as an upload, and a
// missing file refused before anything is sent.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <sstream>
#include <string_view>
#include <thread>

#include "skinspec/store/store.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class ImportCliTest : public ::testing::Test {
 protected:
  static constexpr std::size_t kBodyLimit = 64 * 1024;
  void SetUp() override {
    // A small body limit, so that a file over it is small too: an upload's size is its own.
    rig_ = std::make_unique<AcquisitionRig>(
        rig_options(dir_.path().string(), {"--time-scale", "0"}, {"--body-limit", std::to_string(kBodyLimit)}));
    ASSERT_NE(rig_->port, 0) << rig_->logs();
  }
  ProcessResult skinspec(std::vector<std::string> args) const {
    args.insert(args.end(), {"--server", rig_->url()});
    return run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args, ProcessOptions{std::nullopt, 300s, {}});
  }
  std::string example(const std::string& name) const {
    return std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/" + name;
  }
  std::string write(const std::string& name, const std::string& text) const {
    const auto path = dir_.file(name);
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  // The example's first spectrum under new names: at least `rows` of them and `bytes` in all.
  std::string archive(std::size_t rows, std::size_t bytes = 0) const {
    std::istringstream example_rows(read_text(example("import-rows-percent.csv")));
    std::string header, row;
    std::getline(example_rows, header);
    std::getline(example_rows, row);
    const std::string values = row.substr(row.find(','));
    std::string out = header + "\n";
    for (std::size_t i = 0; i < rows || out.size() < bytes; ++i)
      out += "\"s" + std::to_string(i) + "\"" + values + "\n";
    return out;
  }
  json session(long long id) const { return get_json(rig_->port, "/api/v1/sessions/" + std::to_string(id)); }
  // A session as stored, read from the database itself (read-only beside the daemon): for
  // sessions whose answer would be tens of megabytes, or while the daemon is down.
  store::SessionDetail stored_session(long long id) const {
    store::OpenOptions read_only;
    read_only.mode = store::OpenMode::read_only;
    auto db = value_of(store::Store::open(rig_->db_path(), read_only));
    return value_of(db.session_detail(id));
  }

  ScratchDirectory dir_;
  std::unique_ptr<AcquisitionRig> rig_;
};

TEST_F(ImportCliTest, FilesOfEveryLayoutAreImportedIntoANewSession) {
  const auto r = skinspec({"import", example("import-rows-percent.csv"), example("import-columns.csv"),
                           example("import-argyll.ti3"), "--new-session", "forearm:archive-7"});
  ASSERT_EQ(r.exit_status, 0) << r.describe() << rig_->logs();
  EXPECT_NE(r.err.find("session 1 opened: site forearm, subject archive-7"), std::string::npos) << r.err;
  // How each file's values were read; nothing for CGATS, which gives its own scale.
  EXPECT_THAT(r.out, HasSubstr("import-rows-percent.csv: 3 spectra imported into session 1 (job 1), values read "
                               "as percent (auto)\n"));
  EXPECT_THAT(r.out, HasSubstr("import-columns.csv: 2 spectra imported into session 1 (job 2), values read as "
                               "fraction (auto)\n"));
  EXPECT_THAT(r.out, HasSubstr("import-argyll.ti3: 2 spectra imported into session 1 (job 3)\n"));
  // Not a terminal: one line per change of each job, counting spectra.
  EXPECT_EQ(r.err.find('\r'), std::string::npos);
  EXPECT_NE(r.err.find("succeeded, done 3/3 spectra"), std::string::npos) << r.err;
  const json s = session(1);
  ASSERT_GE(s["measurements"].size(), 6u) << s;
  EXPECT_EQ(s["measurements"].size(), s["fits"].size());
  EXPECT_EQ(s["measurements"][0]["kind"], "imported");
}

TEST_F(ImportCliTest, ABadFileIsNamedByLineWithExit2AndTheOthersAreStored) {
  const long long id = new_session(rig_->port, "S1");
  ASSERT_GT(id, 0);
  std::string bad = read_text(example("import-rows-percent.csv"));
  bad.replace(bad.find("28.04"), 5, "2x.04");  // the second spectrum, line 3
  const auto bad_path = write("bad.csv", bad);
  const auto r = skinspec({"import", bad_path, example("import-columns.csv"), "--session", std::to_string(id)});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  EXPECT_NE(r.err.find("1 of 2 files not imported"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("bad.csv:3:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(bad_file)"), std::string::npos) << r.err;
  EXPECT_EQ(session(id)["measurements"].size(), 2u);  // the columns file only
}

// --scale reaches the service: fractions said to be percent are imported as a hundredth of
// them, and percent said to be fractions is refused by its line.
TEST_F(ImportCliTest, TheScaleAskedForIsHowTheServiceReadsTheFile) {
  const long long id = new_session(rig_->port, "S4");
  const auto percent = example("import-rows-percent.csv");
  const auto refused = skinspec({"import", percent, "--session", std::to_string(id), "--scale", "fraction"});
  EXPECT_EQ(refused.exit_status, 2) << refused.describe();
  EXPECT_THAT(refused.err, HasSubstr("import-rows-percent.csv:2:4: 25.03 is not a reflectance (-0.05 to 1.5)"));
  EXPECT_EQ(session(id)["measurements"].size(), 0u);

  const auto r = skinspec({"import", percent, "--session", std::to_string(id), "--scale", "percent", "--json"});
  ASSERT_EQ(r.exit_status, 0) << r.describe() << rig_->logs();
  const json job = json::parse(r.out);
  EXPECT_EQ(job["request"]["scale"], "percent") << job;
  EXPECT_EQ(job["result"]["scale"], "percent") << job;
  const json s = session(id);
  ASSERT_EQ(s["measurements"].size(), 3u) << s;
  const auto first = s["measurements"][0]["id"].get<long long>();
  const json m = get_json(rig_->port, "/api/v1/measurements/" + std::to_string(first));
  EXPECT_DOUBLE_EQ(m["reflectance"]["values"][0].get<double>(), 0.2503);
  EXPECT_EQ(m["provenance"]["settings"]["source"]["scale"], "percent") << m;

  const auto cgats =
      skinspec({"import", example("import-argyll.ti3"), "--session", std::to_string(id), "--scale", "percent"});
  EXPECT_EQ(cgats.exit_status, 2) << cgats.describe();
  EXPECT_THAT(cgats.err, HasSubstr("import-argyll.ti3: scale percent is for CSV files"));
}

TEST_F(ImportCliTest, AFileLargerThanTheBodyLimitIsAnUpload) {
  const long long id = new_session(rig_->port, "S2");
  const auto r = skinspec(
      {"import", write("big.csv", archive(0, kBodyLimit + kBodyLimit / 4)), "--session", std::to_string(id), "--json"});
  ASSERT_EQ(r.exit_status, 0) << r.describe() << rig_->logs();
  const json job = json::parse(r.out);
  EXPECT_EQ(job["state"], "succeeded");
  EXPECT_EQ(session(id)["measurements"].size(), job["result"]["imported"].get<std::size_t>());
}

TEST_F(ImportCliTest, WhatCannotBeSentIsRefusedBeforeAnything) {
  const long long id = new_session(rig_->port, "S3");
  auto r =
      skinspec({"import", example("import-columns.csv"), dir_.file("missing.csv"), "--session", std::to_string(id)});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  EXPECT_NE(r.err.find("missing.csv: no such file"), std::string::npos) << r.err;
  EXPECT_EQ(session(id)["measurements"].size(), 0u);
  r = skinspec({"import", example("import-columns.csv")});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  r = skinspec({"import", example("import-columns.csv"), "--session", "1", "--new-session", "forearm:x"});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  r = skinspec({"import", example("import-columns.csv"), "--new-session", "forearm"});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  r = skinspec({"import", example("import-columns.csv"), "--session", std::to_string(id), "--model", "paper"});
  EXPECT_EQ(r.exit_status, 2) << r.describe();  // an existing session keeps its model
  r = skinspec({"import", example("import-columns.csv"), "--session", "999"});
  EXPECT_EQ(r.exit_status, 2) << r.describe();
  EXPECT_NE(r.err.find("404"), std::string::npos) << r.err;
}

// A refit job of the service killed with its daemon and posted again once the daemon is back:
// the killed job is failed as interrupted, and between them the two runs refit every
// measurement exactly once.
TEST_F(ImportCliTest, ARefitKilledWithItsDaemonIsResumedByPostingItAgain) {
  const auto imported = skinspec({"import", write("archive.csv", archive(4000)), "--new-session", "forearm:A1"});
  ASSERT_EQ(imported.exit_status, 0) << imported.describe();

  const json refit = json::parse(http_request(rig_->port, "POST", "/api/v1/refits", R"({"model": "paper"})",
                                              {{"Content-Type", "application/json"}})
                                     .body);
  const auto job = "/api/v1/jobs/" + refit["id"].dump();
  for (auto deadline = std::chrono::steady_clock::now() + 60s;
       get_json(rig_->port, job)["progress"].value("spectra_done", 0) == 0;) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << get_json(rig_->port, job);
    std::this_thread::sleep_for(2ms);
  }
  rig_->stop_daemon(SIGKILL);
  rig_->restart_daemon();
  ASSERT_NE(rig_->port, 0) << rig_->logs();
  const json killed = get_json(rig_->port, job);
  EXPECT_EQ(killed["state"], "failed") << killed;
  EXPECT_EQ(killed["error"]["code"], "interrupted") << killed;
  const auto paper_fits = [&] {
    std::size_t n = 0;
    for (const auto& f : stored_session(1).fits) n += f.model == "paper";
    return n;
  };
  const std::size_t before = paper_fits();
  EXPECT_GT(before, 0u);
  EXPECT_LT(before, 4000u);

  const json again = json::parse(http_request(rig_->port, "POST", "/api/v1/refits", R"({"model": "paper"})",
                                              {{"Content-Type", "application/json"}})
                                     .body);
  const json done = wait_for_job(rig_->port, again, 120s);
  ASSERT_EQ(done["state"], "succeeded") << done;
  EXPECT_EQ(done["result"]["refitted"].get<std::size_t>(), 4000 - before);
  EXPECT_EQ(paper_fits(), 4000u);
}

// An import job killed with its daemon, once as soon as some of its batches are committed (and
// not published) and once while its spectra are fitted: nothing of the file is seen in its
// session, before the daemon is back or after; the daemon's opening removes the committed
// batches, and fails the killed job as interrupted (its session too, as any open session of a
// killed daemon); the same file posted again to a new session once the daemon is back is
// imported whole.
TEST_F(ImportCliTest, AnImportKilledWithItsDaemonLeavesNothingOfTheFile) {
  // Four batches of 1,024: staged in more than one transaction, and fitted for long enough to
  // be killed at work. (20,000 took 37 processor-seconds under ASan, mostly fitting them all at
  // the end, and passed 60 s on a busy machine.)
  constexpr std::size_t kSpectra = 4096;
  const std::string file = archive(kSpectra);
  const auto post = [&](long long session) {
    const auto posted = http_request(rig_->port, "POST", "/api/v1/sessions/" + std::to_string(session) + "/imports",
                                     file, {{"Content-Type", "text/csv"}});
    EXPECT_EQ(posted.status, 202) << posted.body;
    return posted.json();
  };
  const auto stored_in = [&](long long session) {
    const auto detail = stored_session(session);
    return std::pair{detail.measurements.size(), detail.fits.size()};
  };
  // Its rows in the file, seen or not (an unpublished import's are not).
  const auto rows_in = [&](long long session) {
    return sqlite_integer(rig_->db_path(),
                          "SELECT count(*) FROM measurements WHERE session_id = " + std::to_string(session));
  };
  // First once a batch (1,024 spectra, of 4,096) is committed: the job is still running.
  struct Moment {
    const char* name;
    std::function<bool(long long session, const json& job)> reached;
  };
  const Moment moments[] = {
      {"staged", [&](long long session, const json&) { return rows_in(session) > 0; }},
      {"fitting",
       [](long long, const json& job) {
         return job["progress"].value("phase", "") == "fitting" && job["progress"].value("spectra_done", 0) > 0;
       }},
  };
  for (const auto& moment : moments) {
    SCOPED_TRACE(moment.name);
    const long long session = new_session(rig_->port, std::string("K-") + moment.name);
    ASSERT_GT(session, 0);
    const auto job = "/api/v1/jobs/" + post(session)["id"].dump();
    for (auto deadline = std::chrono::steady_clock::now() + 60s;;) {
      const json now = get_json(rig_->port, job);
      ASSERT_TRUE(now["state"] == "queued" || now["state"] == "running") << now;  // killed before it ends
      if (moment.reached(session, now)) break;
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << now;
      std::this_thread::sleep_for(1ms);
    }
    rig_->stop_daemon(SIGKILL);
    EXPECT_EQ(stored_in(session), (std::pair<std::size_t, std::size_t>{0, 0}));
    if (moment.name == std::string_view("staged")) {
      EXPECT_GT(rows_in(session), 0);
    }
    rig_->restart_daemon();
    ASSERT_NE(rig_->port, 0) << rig_->logs();
    const json killed = get_json(rig_->port, job);
    EXPECT_EQ(killed["state"], "failed") << killed;
    EXPECT_EQ(killed["error"]["code"], "interrupted") << killed;
    EXPECT_EQ(stored_in(session), (std::pair<std::size_t, std::size_t>{0, 0}));
    EXPECT_EQ(rows_in(session), 0);
  }
  const long long session = new_session(rig_->port, "K-again");
  const json done = wait_for_job(rig_->port, post(session), 120s);
  ASSERT_EQ(done["state"], "succeeded") << done;
  EXPECT_EQ(stored_in(session), (std::pair<std::size_t, std::size_t>{kSpectra, kSpectra}));
}

}  // namespace
}  // namespace skinspec::testing
