// Imports and refits as jobs of the service, through the router and its FitJobs with a real
// store and the shipped model: 202 and the job, progress in spectra followed through its
// events, a bad file failed with its line and nothing stored, cancel while queued and while
// running, a refit cancelled and resumed that refits every measurement exactly once, and the
// requests refused before any job is made.

#include <gtest/gtest.h>

#include <sstream>
#include <thread>

#include "skinspec/api/router.hpp"
#include "skinspec/store/store.hpp"
#include "support/data.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::api {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

// The example of a Konica Minolta export, its rows repeated under new names to make `count`.
std::string rows_file(std::size_t count) {
  std::istringstream example(testing::data_file("examples/import-rows-percent.csv"));
  std::string header;
  std::getline(example, header);
  std::vector<std::string> rows;
  for (std::string line; std::getline(example, line);)
    if (!line.empty()) rows.push_back(line.substr(line.find(',')));  // without the name
  std::string out = header + "\n";
  for (std::size_t i = 0; i < count; ++i) out += "\"s" + std::to_string(i) + "\"" + rows[i % rows.size()] + "\n";
  return out;
}

class FitJobsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_.emplace(testing::value_of(store::Store::open(dir_.file("lab.db"))));
    RouterContext context;
    context.store = &*db_;
    context.fitter = &testing::shipped_fitter();
    router_ = std::make_unique<Router>(context);
    session_ = new_session();
  }
  store::Id new_session() {
    auto session = testing::sample_session(1);
    session.model = "extended";
    return testing::value_of(db_->create_session(session));
  }
  Response post_import(const std::string& bytes, const std::string& query = "?name=lab.csv",
                       std::map<std::string, std::string> headers = {{"content-type", "text/csv"}},
                       store::Id session = 0) const {
    const auto target = "/api/v1/sessions/" + std::to_string(session ? session : session_) + "/imports" + query;
    return router_->handle(Request{"POST", target, std::move(headers), bytes});
  }
  Response post_refit(const json& body) const {
    return router_->handle(Request{"POST", "/api/v1/refits", {{"content-type", "application/json"}}, body.dump()});
  }
  static json accepted(const Response& r) {
    EXPECT_EQ(r.status, 202) << r.body;
    return json::parse(r.body, nullptr, false);
  }
  json get_job(long long id) const {
    return json::parse(router_->handle(Request{"GET", "/api/v1/jobs/" + std::to_string(id), {}, ""}).body);
  }
  Response cancel(long long id) const {
    return router_->handle(Request{"DELETE", "/api/v1/jobs/" + std::to_string(id), {}, ""});
  }
  // The job's events until it ends; the last is the job as it ended.
  std::vector<json> follow(long long id) const {
    const auto r = router_->handle(Request{"GET", "/api/v1/jobs/" + std::to_string(id) + "/events", {}, ""});
    EXPECT_EQ(r.status, 200) << r.body;
    std::vector<json> seen;
    for (int i = 0; i < 100000 && r.events; ++i) {
      const auto event = r.events->next(60s);
      if (!event) break;
      if (const auto data = event->find("data: "); data != std::string::npos)
        seen.push_back(json::parse(event->substr(data + 6)));
    }
    return seen;
  }
  // Waits until the job's progress has spectra done; whether it did within a minute.
  bool wait_for_work(long long id) const {
    for (auto deadline = std::chrono::steady_clock::now() + 60s; std::chrono::steady_clock::now() < deadline;) {
      const json job = get_job(id);
      if (job["state"] != "running" && job["state"] != "queued") return false;
      if (job["progress"].value("spectra_done", 0) > 0) return true;
      std::this_thread::sleep_for(1ms);
    }
    return false;
  }
  std::size_t stored(store::Id session) const {
    return testing::value_of(db_->session_detail(session)).measurements.size();
  }

  testing::ScratchDirectory dir_;
  std::optional<store::Store> db_;
  std::unique_ptr<Router> router_;
  store::Id session_ = 0;
};

TEST_F(FitJobsTest, AnImportIsAJobWhoseSpectraAreStoredWithItsEnd) {
  const auto r = post_import(rows_file(600));
  const json job = accepted(r);
  EXPECT_EQ(job["kind"], "import");
  EXPECT_EQ(job["session_id"], session_);
  EXPECT_EQ(job["request"]["source"], "lab.csv");
  EXPECT_EQ(job["request"]["format"], "csv");
  EXPECT_NE(
      std::ranges::find(r.headers, std::pair<std::string, std::string>{"Location", "/api/v1/jobs/" + job["id"].dump()}),
      r.headers.end());

  const auto events = follow(job["id"]);
  ASSERT_FALSE(events.empty());
  const json& last = events.back();
  ASSERT_EQ(last["state"], "succeeded") << last;
  EXPECT_EQ(last["result"]["imported"], 600);
  EXPECT_EQ(last["progress"]["phase"], "done");
  EXPECT_EQ(last["progress"]["spectra_done"], 600);
  // Progress counted spectra on the way, with the time left once there was a rate.
  bool fitting_seen = false;
  for (const auto& e : events) {
    if (e["progress"]["phase"] != "fitting") continue;
    fitting_seen = true;
    EXPECT_EQ(e["progress"]["spectra_total"], 600) << e;
    EXPECT_LE(e["progress"]["spectra_done"].get<int>(), 600);
    EXPECT_EQ(e["progress"]["remaining_s"].is_number(), e["progress"]["spectra_done"].get<int>() > 0) << e;
  }
  EXPECT_TRUE(fitting_seen);

  const auto detail = testing::value_of(db_->session_detail(session_));
  ASSERT_EQ(detail.measurements.size(), 600u);
  EXPECT_EQ(detail.fits.size(), 600u);
  for (const auto& m : detail.measurements) {
    EXPECT_EQ(m.kind, store::MeasurementKind::imported);
    EXPECT_EQ(m.job_id, job["id"].get<store::Id>());
  }
}

TEST_F(FitJobsTest, ABadFileFailsTheJobByLineAndStoresNothing) {
  std::string bytes = rows_file(5);
  const auto third_row = bytes.find("\"s2\"");
  bytes.replace(bytes.find(',', bytes.find(',', bytes.find(',', third_row) + 1) + 1) + 1, 5, "abc");
  const json job = accepted(post_import(bytes));
  const json last = follow(job["id"]).back();
  EXPECT_EQ(last["state"], "failed");
  EXPECT_EQ(last["error"]["code"], "bad_file");
  EXPECT_NE(last["error"]["message"].get<std::string>().find("lab.csv:4:"), std::string::npos) << last;
  EXPECT_EQ(stored(session_), 0u);
}

TEST_F(FitJobsTest, TheFormatIsRecognisedOrGivenAndCgatsImports) {
  const json job = accepted(post_import(testing::data_file("examples/import-argyll.ti3"), "", {}));
  EXPECT_EQ(job["request"]["format"], "cgats");
  EXPECT_EQ(job["request"]["source"], "upload");
  const json last = follow(job["id"]).back();
  ASSERT_EQ(last["state"], "succeeded") << last;
  EXPECT_GT(last["result"]["imported"].get<int>(), 0);
  // Said to be CGATS, a CSV file is refused as one.
  const json forced = accepted(post_import(rows_file(2), "?format=cgats"));
  EXPECT_EQ(follow(forced["id"]).back()["error"]["code"], "bad_file");
}

// The scale of a CSV file's values, auto unless said: kept with the request, and how the job
// read the file in its result.
TEST_F(FitJobsTest, TheScaleIsAutoOrGiven) {
  const json automatic = accepted(post_import(rows_file(2)));
  EXPECT_EQ(automatic["request"]["scale"], "auto");
  const json read = follow(automatic["id"]).back();
  ASSERT_EQ(read["state"], "succeeded") << read;
  EXPECT_EQ(read["result"]["scale"], "percent");
  // Percent said to be fractions: refused at the first value, in the fourth field of line 2.
  const json fractions = accepted(post_import(rows_file(2), "?name=lab.csv&scale=fraction"));
  EXPECT_EQ(fractions["request"]["scale"], "fraction");
  const json refused = follow(fractions["id"]).back();
  EXPECT_EQ(refused["error"]["code"], "bad_file") << refused;
  EXPECT_NE(refused["error"]["message"].get<std::string>().find("lab.csv:2:4: 25.03 is not a reflectance"),
            std::string::npos)
      << refused;
  const json argyll = accepted(post_import(testing::data_file("examples/import-argyll.ti3"), "?scale=auto", {}));
  const json cgats = follow(argyll["id"]).back();
  ASSERT_EQ(cgats["state"], "succeeded") << cgats;
  EXPECT_TRUE(cgats["result"]["scale"].is_null()) << cgats;
  EXPECT_EQ(stored(session_), 2u + 2u);
}

TEST_F(FitJobsTest, RequestsThatCannotBeImportedAreRefusedWithoutAJob) {
  const std::string file = rows_file(2);
  EXPECT_EQ(post_import(file, "?format=xlsx").status, 400);
  const auto scale = post_import(file, "?scale=percentage");
  EXPECT_EQ(scale.status, 400);
  EXPECT_NE(scale.body.find("'scale' must be auto, fraction or percent"), std::string::npos) << scale.body;
  EXPECT_EQ(post_import(file, "?sheet=1").status, 400);
  EXPECT_EQ(post_import(file, "?name=").status, 400);
  EXPECT_EQ(post_import(file, "?name=a%0Ab").status, 400);
  EXPECT_EQ(post_import(file, "", {{"content-type", "application/json"}}).status, 415);
  EXPECT_EQ(post_import(file, "", {{"content-type", "image/png"}}).status, 415);
  EXPECT_EQ(post_import("").status, 422);
  EXPECT_EQ(post_import(file, "", {{"content-type", "text/csv"}}, 999).status, 404);
  testing::value_of(db_->update_session(session_, {.notes = std::nullopt, .state = store::SessionState::complete}));
  const auto closed = post_import(file);
  EXPECT_EQ(closed.status, 409) << closed.body;
  EXPECT_EQ(testing::value_of(db_->jobs()).size(), 0u);
}

TEST_F(FitJobsTest, AQueuedImportAndARunningOneAreCancelledWithNothingStored) {
  // Both posted at once: a job posted while an import stores waits for the database's writer.
  const json big = accepted(post_import(rows_file(20000)));
  const json queued = accepted(post_import(rows_file(3)));
  ASSERT_TRUE(wait_for_work(big["id"]));
  EXPECT_EQ(get_job(queued["id"])["position"], 1);
  // The running one first: the queued one's end is a write, which would wait for the import.
  ASSERT_EQ(cancel(big["id"]).status, 200);
  const auto first = cancel(queued["id"]);
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(json::parse(first.body)["state"], "cancelled");
  EXPECT_EQ(cancel(queued["id"]).status, 200);  // again: it is cancelled

  const json last = follow(big["id"]).back();
  EXPECT_EQ(last["state"], "cancelled") << last;
  EXPECT_EQ(last["error"]["code"], "cancelled");
  EXPECT_EQ(follow(queued["id"]).back()["state"], "cancelled");
  EXPECT_EQ(stored(session_), 0u);
  EXPECT_EQ(cancel(big["id"]).status, 200);
}

TEST_F(FitJobsTest, ARefitCancelledThenPostedAgainRefitsEachMeasurementOnce) {
  // Enough rows that the cancel lands mid-run even when a busy machine delays it: 2,000 were
  // sometimes all refitted before it arrived.
  constexpr int kRows = 6000;
  const json imported = accepted(post_import(rows_file(kRows)));
  ASSERT_EQ(follow(imported["id"]).back()["state"], "succeeded");

  const json refit = accepted(post_refit({{"model", "paper"}, {"session_id", session_}}));
  EXPECT_EQ(refit["kind"], "refit");
  EXPECT_TRUE(refit["session_id"].is_null());  // a refit is no session's acquisition
  ASSERT_TRUE(wait_for_work(refit["id"]));
  ASSERT_EQ(cancel(refit["id"]).status, 200);
  const json stopped = follow(refit["id"]).back();
  ASSERT_EQ(stopped["state"], "cancelled") << stopped;
  const int first_run = stopped["result"].value("refitted", 0);
  EXPECT_GT(first_run, 0);
  EXPECT_LT(first_run, kRows);

  const json again = accepted(post_refit({{"model", "paper"}, {"session_id", session_}}));
  const auto events = follow(again["id"]);
  const json& last = events.back();
  ASSERT_EQ(last["state"], "succeeded") << last;
  EXPECT_EQ(last["result"]["refitted"], kRows - first_run);
  EXPECT_EQ(last["result"]["total"], kRows - first_run);
  EXPECT_EQ(last["progress"]["spectra_done"], kRows - first_run);
  // Two fits per measurement now: its import's, and one paper fit from either run.
  EXPECT_EQ(testing::value_of(db_->session_detail(session_)).fits.size(), 2u * kRows);

  const json nothing_left = accepted(post_refit({{"model", "paper"}}));
  EXPECT_EQ(follow(nothing_left["id"]).back()["result"]["refitted"], 0);
  EXPECT_EQ(cancel(nothing_left["id"]).status, 409);  // it has ended
}

TEST_F(FitJobsTest, StoppingTheServiceEndsTheRunningJobAndTheQueuedOnesAsStopped) {
  const json big = accepted(post_import(rows_file(20000)));
  const json queued = accepted(post_refit({{"model", "paper"}}));
  ASSERT_TRUE(wait_for_work(big["id"]));
  router_.reset();  // as skinspecd does when it stops
  for (const auto& job : {big, queued}) {
    const auto record = testing::value_of(db_->job(job["id"].get<store::Id>()));
    EXPECT_EQ(record.state, store::JobState::cancelled) << job["id"];
    ASSERT_TRUE(record.error);
    EXPECT_EQ(record.error->code, store::JobErrorCode::stopped);
  }
  EXPECT_EQ(stored(session_), 0u);
}

TEST_F(FitJobsTest, RefitRequestsAreChecked) {
  EXPECT_EQ(post_refit({{"model", "nonsense"}}).status, 422);
  EXPECT_EQ(post_refit({{"session_id", "one"}}).status, 422);
  EXPECT_EQ(post_refit({{"session_id", 0}}).status, 422);
  EXPECT_EQ(post_refit({{"session_id", 4242}}).status, 404);
  EXPECT_EQ(post_refit({{"site", "cheek"}}).status, 422);
  EXPECT_EQ(router_->handle(Request{"POST", "/api/v1/refits", {{"content-type", "text/plain"}}, "{}"}).status, 415);
  const auto keyed = [&] {
    return router_->handle(
        Request{"POST", "/api/v1/refits", {{"content-type", "application/json"}, {"idempotency-key", "k1"}}, "{}"});
  };
  const auto first = keyed();
  ASSERT_EQ(first.status, 202) << first.body;
  const auto second = keyed();
  EXPECT_EQ(second.status, 200);
  EXPECT_EQ(json::parse(second.body)["id"], json::parse(first.body)["id"]);
  // The key of a refit does not name an import.
  EXPECT_EQ(post_import(rows_file(2), "", {{"content-type", "text/csv"}, {"idempotency-key", "k1"}}).status, 409);
}

}  // namespace
}  // namespace skinspec::api
