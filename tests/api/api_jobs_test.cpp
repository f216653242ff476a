// Jobs through the router, without sockets: the job JSON's position and progress, from a fake
// acquisition while a job is live and from the store once it has finished, and the job's
// Server-Sent Events pulled from the response's event source.

#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <map>
#include <mutex>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::api {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

// Live progress set by the test; the jobs themselves are in the store.
class FakeAcquisition final : public Acquisition, public JobWatch {
 public:
  const JobWatch& jobs() const override { return *this; }
  json instrument_status() const override {
    return {{"device", "fake"}, {"state", "connected"}, {"last_error", nullptr}};
  }
  json ports() const override { return {{"ports", json::array()}}; }
  // Like a worker that was idle: the job is queued and taken at once, before the answer is
  // made from it.
  std::expected<store::CreatedJob, ApiError> submit(store::Id session, const MeasureRequest& request,
                                                    const std::string&) override {
    if (db_ == nullptr) return std::unexpected(ApiError{ErrorKind::unavailable, "unavailable", "not in this test"});
    store::Job job;
    job.kind = "measure";
    job.session_id = session;
    const auto created = db_->create_job(job);
    if (!created) return std::unexpected(ApiError{ErrorKind::internal, "", created.error().message});
    set(created->job.id, JobProgress{1, JobPhase::queued, 0, request.count});
    if (!db_->update_job(created->job.id, {store::JobState::running}))
      return std::unexpected(ApiError{ErrorKind::internal, "", "start"});
    set(created->job.id, JobProgress{0, JobPhase::connecting, 0, request.count});
    return *created;
  }
  void take_jobs_from(store::Store& db) { db_ = &db; }
  std::expected<store::Job, ApiError> cancel(store::Id) override {
    return std::unexpected(ApiError{ErrorKind::unavailable, "unavailable", "not in this test"});
  }
  std::optional<JobProgress> progress(store::Id job_id) const override {
    std::lock_guard lock(mutex_);
    const auto it = live_.find(job_id);
    return it == live_.end() ? std::nullopt : std::optional<JobProgress>(it->second);
  }
  std::uint64_t changes() const override {
    std::lock_guard lock(mutex_);
    return changes_;
  }
  std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                const std::atomic<bool>& abandoned) const override {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return changes_ > seen || abandoned.load(); });
    return changes_;
  }
  void wake_waiters() const override {
    std::lock_guard lock(mutex_);
    changed_.notify_all();
  }

  void set(store::Id id, std::optional<JobProgress> progress) {
    std::lock_guard lock(mutex_);
    if (progress) live_[id] = *progress;
    else live_.erase(id);
    ++changes_;
    changed_.notify_all();
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::map<store::Id, JobProgress> live_;
  std::uint64_t changes_ = 0;
  store::Store* db_ = nullptr;
};

class ApiJobsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto opened = store::Store::open(dir_.file("jobs.db"));
    ASSERT_TRUE(opened) << opened.error().message;
    db_.emplace(std::move(*opened));
    RouterContext context;
    context.store = &*db_;
    context.acquisition = &acquisition_;
    router_ = std::make_unique<Router>(context);
    const auto session = db_->create_session(testing::sample_session(1));
    ASSERT_TRUE(session);
    session_ = *session;
  }
  store::Id add_job(int count) {
    store::Job job;
    job.kind = "measure";
    job.session_id = session_;
    job.request = json{{"kind", "sample"}, {"count", count}}.dump();
    auto created = db_->create_job(job);
    EXPECT_TRUE(created) << created.error().message;
    return created->job.id;
  }
  void update(store::Id id, store::JobState state, std::optional<store::JobError> error = {},
              std::optional<std::string> result = {}) {
    auto updated = db_->update_job(id, {state, std::move(error), std::move(result)});
    ASSERT_TRUE(updated) << updated.error().message;
  }
  store::Job value_of_record(store::Id id) const {
    auto job = db_->job(id);
    EXPECT_TRUE(job) << job.error().message;
    return job ? *job : store::Job{};
  }
  json get_job(store::Id id) const {
    const auto r = router_->handle(Request{"GET", "/api/v1/jobs/" + std::to_string(id), {}, ""});
    EXPECT_EQ(r.status, 200) << r.body;
    return json::parse(r.body);
  }
  std::shared_ptr<EventSource> events_of(store::Id id) const {
    const auto r = router_->handle(Request{"GET", "/api/v1/jobs/" + std::to_string(id) + "/events", {}, ""});
    EXPECT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.content_type, "text/event-stream");
    return r.events;
  }
  // The job in an event "id: N\nevent: job\ndata: {...}\n\n", and its id.
  static std::pair<int, json> parse_event(const std::string& event) {
    EXPECT_EQ(event.rfind("id: ", 0), 0u) << event;
    EXPECT_NE(event.find("\nevent: job\ndata: "), std::string::npos) << event;
    EXPECT_EQ(event.substr(event.size() - 2), "\n\n");
    const auto data = event.find("data: ") + 6;
    return {std::stoi(event.substr(4)), json::parse(event.substr(data, event.size() - 2 - data))};
  }

  testing::ScratchDirectory dir_;
  std::optional<store::Store> db_;
  FakeAcquisition acquisition_;
  std::unique_ptr<Router> router_;
  store::Id session_ = 0;
};

TEST_F(ApiJobsTest, LiveJobsShowTheirPositionAndProgress) {
  const auto running = add_job(4), queued = add_job(2);
  update(running, store::JobState::running);
  acquisition_.set(running, JobProgress{0, JobPhase::measuring, 2, 4});
  acquisition_.set(queued, JobProgress{1, JobPhase::queued, 0, 2});

  const json a = get_job(running);
  EXPECT_EQ(a["state"], "running");
  EXPECT_EQ(a["position"], 0);
  EXPECT_EQ(a["progress"]["phase"], "measuring");
  EXPECT_EQ(a["progress"]["readings_done"], 2);
  EXPECT_EQ(a["progress"]["readings_total"], 4);
  EXPECT_DOUBLE_EQ(a["progress"]["fraction"].get<double>(), 0.45);  // measuring covers 0 to 0.9
  const json b = get_job(queued);
  EXPECT_EQ(b["position"], 1);
  EXPECT_EQ(b["progress"]["phase"], "queued");
  EXPECT_DOUBLE_EQ(b["progress"]["fraction"].get<double>(), 0.0);
  acquisition_.set(running, JobProgress{0, JobPhase::storing, 4, 4});
  EXPECT_DOUBLE_EQ(get_job(running)["progress"]["fraction"].get<double>(), 0.95);
}

TEST_F(ApiJobsTest, FinishedJobsShowTheirStoredProgress) {
  const auto ok = add_job(3), failed = add_job(5), cancelled = add_job(2);
  update(ok, store::JobState::running);
  update(ok, store::JobState::succeeded, std::nullopt, json{{"measurement_id", 1}, {"readings", 3}}.dump());
  update(failed, store::JobState::running);
  update(failed, store::JobState::failed, store::JobError{store::JobErrorCode::lost, "the meter went away"},
         json{{"readings", 2}}.dump());
  update(cancelled, store::JobState::cancelled,
         store::JobError{store::JobErrorCode::cancelled, "cancelled by request"});
  // Live progress not yet cleared does not override a finished record.
  acquisition_.set(ok, JobProgress{0, JobPhase::storing, 3, 3});

  const json a = get_job(ok);
  EXPECT_TRUE(a["position"].is_null());
  EXPECT_EQ(a["progress"], (json{{"phase", "done"}, {"readings_done", 3}, {"readings_total", 3}, {"fraction", 1.0}}));
  const json b = get_job(failed);
  EXPECT_TRUE(b["position"].is_null());
  EXPECT_EQ(b["progress"]["phase"], "done");
  EXPECT_EQ(b["progress"]["readings_done"], 2);
  EXPECT_EQ(b["progress"]["readings_total"], 5);
  EXPECT_LT(b["progress"]["fraction"].get<double>(), 1.0);
  const json c = get_job(cancelled);
  EXPECT_EQ(c["progress"]["readings_done"], 0);
  EXPECT_DOUBLE_EQ(c["progress"]["fraction"].get<double>(), 0.0);
}

TEST_F(ApiJobsTest, EventsFollowAJobUntilItEnds) {
  const auto id = add_job(2);
  acquisition_.set(id, JobProgress{1, JobPhase::queued, 0, 2});
  const auto events = events_of(id);
  ASSERT_TRUE(events);

  auto [first_id, first] = parse_event(events->next(1s).value());
  EXPECT_EQ(first_id, 1);
  EXPECT_EQ(first["position"], 1);
  // Nothing changed: a keep-alive comment.
  EXPECT_EQ(events->next(10ms), ": keep-alive\n\n");
  // A change of another job is no event of this one.
  acquisition_.set(id + 100, JobProgress{});
  EXPECT_EQ(events->next(10ms), ": keep-alive\n\n");

  update(id, store::JobState::running);
  acquisition_.set(id, JobProgress{0, JobPhase::measuring, 1, 2});
  auto [second_id, second] = parse_event(events->next(1s).value());
  EXPECT_EQ(second_id, 2);
  EXPECT_EQ(second["state"], "running");
  EXPECT_EQ(second["progress"]["readings_done"], 1);

  update(id, store::JobState::succeeded, std::nullopt,
         json{{"measurement_id", 7}, {"fit_id", 3}, {"readings", 2}}.dump());
  acquisition_.set(id, std::nullopt);
  auto [last_id, last] = parse_event(events->next(1s).value());
  EXPECT_EQ(last_id, 3);
  EXPECT_EQ(last["state"], "succeeded");
  EXPECT_EQ(last["result"]["fit_id"], 3);
  EXPECT_FALSE(events->next(10ms).has_value());
}

TEST_F(ApiJobsTest, AFinishedJobGivesOneEventAndAnUnknownOneIsNotFound) {
  const auto id = add_job(1);
  update(id, store::JobState::cancelled, store::JobError{store::JobErrorCode::cancelled, "cancelled by request"});
  const auto events = events_of(id);
  ASSERT_TRUE(events);
  EXPECT_EQ(parse_event(events->next(1s).value()).second["state"], "cancelled");
  EXPECT_FALSE(events->next(1s).has_value());

  const auto missing = router_->handle(Request{"GET", "/api/v1/jobs/999/events", {}, ""});
  EXPECT_EQ(missing.status, 404);
  EXPECT_FALSE(missing.events);
  EXPECT_EQ(json::parse(missing.body)["error"]["code"], "not_found");
}

TEST_F(ApiJobsTest, ClosingTheEventsEndsAWaitingPull) {
  const auto id = add_job(1);
  acquisition_.set(id, JobProgress{1, JobPhase::queued, 0, 1});
  const auto events = events_of(id);
  ASSERT_TRUE(events->next(1s).has_value());
  std::thread closer([&] { events->close(); });
  // Without the close this would wait an hour for a keep-alive.
  EXPECT_FALSE(events->next(std::chrono::hours(1)).has_value());
  closer.join();
}

// The record read a moment before the live progress may still say queued: the job is shown
// as the progress says, never queued at position 0.
TEST_F(ApiJobsTest, ANewJobTheWorkerTookAtOnceShowsRunningAtPositionZero) {
  acquisition_.take_jobs_from(*db_);
  const auto r = router_->handle(Request{"POST",
                                         "/api/v1/sessions/" + std::to_string(session_) + "/measurements",
                                         {{"content-type", "application/json"}},
                                         R"({"kind": "white", "count": 3})"});
  ASSERT_EQ(r.status, 202) << r.body;
  const json accepted = json::parse(r.body);
  EXPECT_EQ(accepted["state"], "running");
  EXPECT_EQ(accepted["position"], 0);
  EXPECT_EQ(accepted["progress"]["phase"], "connecting");
  EXPECT_TRUE(accepted["error"].is_null());
}

TEST_F(ApiJobsTest, PositionIsOneOrMoreWhileQueuedZeroWhileRunningNullOnceFinished) {
  const auto id = add_job(2);
  acquisition_.set(id, JobProgress{2, JobPhase::queued, 0, 2});
  EXPECT_EQ(get_job(id)["state"], "queued");
  EXPECT_EQ(get_job(id)["position"], 2);
  acquisition_.set(id, JobProgress{0, JobPhase::queued, 0, 2});  // no place known: still a place
  EXPECT_EQ(get_job(id)["position"], 1);
  update(id, store::JobState::running);
  acquisition_.set(id, JobProgress{1, JobPhase::measuring, 1, 2});  // a stale place is not shown
  EXPECT_EQ(get_job(id)["state"], "running");
  EXPECT_EQ(get_job(id)["position"], 0);
  update(id, store::JobState::failed, store::JobError{store::JobErrorCode::no_contact, "no answer on tcp:x"});
  const json failed = get_job(id);
  EXPECT_EQ(failed["state"], "failed");
  EXPECT_TRUE(failed["position"].is_null());
  EXPECT_EQ(failed["error"], (json{{"code", "no_contact"}, {"message", "no answer on tcp:x"}}));
}

// The store refused a job's end: the record stays running, the job shows failed with a store
// error, and its events end there.
TEST_F(ApiJobsTest, AJobWhoseEndTheStoreRefusedShowsFailedWithAStoreError) {
  const auto id = add_job(2);
  update(id, store::JobState::running);
  JobProgress refused{0, JobPhase::done, 1, 2};
  refused.unrecorded_failure =
      store::JobError{store::JobErrorCode::store, "the job ended (lost: gone) but the database refused"};
  acquisition_.set(id, refused);
  const json job = get_job(id);
  EXPECT_EQ(job["state"], "failed");
  EXPECT_TRUE(job["position"].is_null());
  EXPECT_EQ(job["error"]["code"], "store");
  EXPECT_EQ(job["progress"]["phase"], "done");
  EXPECT_EQ(value_of_record(id).state, store::JobState::running);
  const auto events = events_of(id);
  EXPECT_EQ(parse_event(events->next(1s).value()).second["state"], "failed");
  EXPECT_FALSE(events->next(10ms).has_value());
}

TEST_F(ApiJobsTest, TheOpenApiJobSchemaHasPositionAndProgress) {
  const json doc = Router::openapi_document();
  const json& job = doc["components"]["schemas"]["Job"]["properties"];
  EXPECT_TRUE(job.contains("position"));
  EXPECT_EQ(job["progress"]["$ref"], "#/components/schemas/JobProgress");
  EXPECT_TRUE(doc["components"]["schemas"]["JobProgress"]["properties"].contains("fraction"));
  EXPECT_TRUE(
      doc["paths"]["/api/v1/jobs/{id}/events"]["get"]["responses"]["200"]["content"].contains("text/event-stream"));
  // The job's error is {code, message}, its codes those of the one mapping.
  EXPECT_EQ(job["error"]["oneOf"][0]["$ref"], "#/components/schemas/JobError");
  const json& codes = doc["components"]["schemas"]["JobError"]["properties"]["code"]["enum"];
  EXPECT_EQ(codes.size(), store::job_error_code_names().size());
  for (const auto& [code, name] : store::job_error_code_names())
    EXPECT_NE(std::ranges::find(codes, json(name)), codes.end()) << name;
  EXPECT_EQ(doc["components"]["schemas"]["JobProgress"]["properties"]["phase"]["enum"],
            json({"queued", "connecting", "measuring", "reading", "fitting", "storing", "done"}));
  EXPECT_EQ(job["kind"]["enum"], json({"measure", "import", "refit", "map"}));
  // An import takes the file itself as its body, with its format, scale and name in the query.
  const json& import = doc["paths"]["/api/v1/sessions/{id}/imports"]["post"];
  EXPECT_TRUE(import["requestBody"]["content"].contains("text/plain")) << import;
  EXPECT_EQ(import["responses"]["202"]["content"]["application/json"]["schema"]["$ref"], "#/components/schemas/Job");
  EXPECT_EQ(import["parameters"].size(), 4u) << import;  // id, format, scale, name
  EXPECT_EQ(import["parameters"][2]["schema"]["enum"], json({"auto", "fraction", "percent"})) << import;
  EXPECT_EQ(doc["paths"]["/api/v1/refits"]["post"]["requestBody"]["content"]["application/json"]["schema"]["$ref"],
            "#/components/schemas/RefitJobRequest");
}

}  // namespace
}  // namespace skinspec::api
