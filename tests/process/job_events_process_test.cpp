// A job's position, progress and Server-Sent Events with real processes on loopback: skinspecd
// driving skinspec-sim, slowed down so that jobs wait behind each other.

#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/client/http_client.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

// About 0.35 s a reading.
constexpr double kSlow = 0.05;

struct Event {
  long long id = 0;
  json job;
};

// "id: N\nevent: job\ndata: {...}"; nullopt for a comment.
std::optional<Event> parse_event(const std::string& text) {
  if (text.rfind(':', 0) == 0) return std::nullopt;
  Event e;
  std::string name;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const auto eol = std::min(text.find('\n', pos), text.size());
    const std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    if (line.rfind("id: ", 0) == 0) e.id = std::stoll(line.substr(4));
    else if (line.rfind("event: ", 0) == 0) name = line.substr(7);
    else if (line.rfind("data: ", 0) == 0) e.job = json::parse(line.substr(6), nullptr, false);
  }
  EXPECT_EQ(name, "job") << text;
  return e;
}

std::string events_path(long long job) { return "/api/v1/jobs/" + std::to_string(job) + "/events"; }

// Every event of a job's stream until the server ends it.
std::vector<Event> all_events(unsigned short port, long long job, HttpReply* reply = nullptr) {
  std::vector<Event> events;
  const auto r = follow_events(
      port, events_path(job),
      [&](const std::string& text) {
        if (auto e = parse_event(text)) events.push_back(std::move(*e));
        return true;
      },
      120s);
  EXPECT_EQ(r.status, 200) << r.error << r.body;
  EXPECT_TRUE(r.error.empty()) << r.error;
  if (reply) *reply = r;
  return events;
}

struct Stream {
  HttpReply reply;
  std::vector<Event> events;
};

// Follows a job's events on another thread; returns once the first event has come (or the
// stream ended without one), with the whole stream to come.
std::future<Stream> follow_in_background(unsigned short port, long long job) {
  auto first = std::make_shared<std::promise<void>>();
  auto arrived = first->get_future();
  auto stream = std::async(std::launch::async, [port, job, first] {
    Stream out;
    bool told = false;
    const auto tell = [&] {
      if (told) return;
      first->set_value();
      told = true;
    };
    out.reply = follow_events(
        port, events_path(job),
        [&](const std::string& text) {
          if (auto e = parse_event(text)) out.events.push_back(std::move(*e));
          tell();
          return true;
        },
        120s);
    tell();
    return out;
  });
  EXPECT_EQ(arrived.wait_for(60s), std::future_status::ready);
  return stream;
}

class JobEventsTest : public ::testing::Test {
 protected:
  long long open_session() {
    const auto r =
        http_request(port(), "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "E1"}}.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    return r.json().value("id", 0LL);
  }
  long long submit(long long session, const json& body) {
    const auto r =
        http_request(port(), "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements", body.dump());
    EXPECT_EQ(r.status, 202) << r.body;
    return r.json().value("id", 0LL);
  }
  json job(long long id) { return http_request(port(), "GET", "/api/v1/jobs/" + std::to_string(id)).json(); }
  unsigned short port() const { return rig_->port; }

  ScratchDirectory dir_;
  std::unique_ptr<AcquisitionRig> rig_;
};

TEST_F(JobEventsTest, QueuedJobsShowTheirPlaceAndASampleStreamsItsReadingsToItsResult) {
  rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), kSlow));
  ASSERT_NE(port(), 0) << rig_->logs();
  const long long session = open_session();
  const auto white = all_events(port(), submit(session, {{"kind", "white"}}));
  ASSERT_FALSE(white.empty());
  ASSERT_EQ(white.back().job["state"], "succeeded") << white.back().job << rig_->logs();

  // A long white holds the meter; two samples wait behind it.
  const long long blocker = submit(session, {{"kind", "white"}, {"count", 100}});
  const long long sample = submit(session, {{"kind", "sample"}, {"count", 5}});
  const long long last = submit(session, {{"kind", "sample"}});
  const json third = job(last), second = job(sample);
  ASSERT_EQ(job(blocker)["state"], "running") << "the blocker ended early: " << rig_->logs();
  EXPECT_EQ(third["position"], 2) << third;
  EXPECT_EQ(third["progress"]["phase"], "queued");
  EXPECT_EQ(second["position"], 1) << second;
  EXPECT_EQ(job(blocker)["position"], 0);

  // Follow the sample from its place in the queue; cancel the blocker once following.
  auto stream = follow_in_background(port(), sample);
  EXPECT_EQ(http_request(port(), "DELETE", "/api/v1/jobs/" + std::to_string(blocker)).status, 200);
  const auto seen = stream.get().events;

  ASSERT_GE(seen.size(), 3u);
  EXPECT_EQ(seen.front().job["state"], "queued");
  EXPECT_EQ(seen.front().job["position"], 1);
  int readings = 0;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].id, static_cast<long long>(i + 1));
    const int done = seen[i].job["progress"]["readings_done"];
    EXPECT_GE(done, readings) << "readings went back at event " << i;
    readings = done;
    EXPECT_EQ(seen[i].job["progress"]["readings_total"], 5);
    // State and position agree in every event.
    const json& j = seen[i].job;
    if (j["state"] == "queued") {
      EXPECT_GE(j["position"].get<int>(), 1) << j;
    } else if (j["state"] == "running") {
      EXPECT_EQ(j["position"], 0) << j;
    } else {
      EXPECT_TRUE(j["position"].is_null()) << j;
    }
  }
  // The blocker's cancellation says so by its code.
  EXPECT_EQ(job(blocker)["error"], (json{{"code", "cancelled"}, {"message", "cancelled by request"}}));
  EXPECT_EQ(readings, 5);
  const json& final = seen.back().job;
  ASSERT_EQ(final["state"], "succeeded") << final << rig_->logs();
  EXPECT_TRUE(final["position"].is_null());
  EXPECT_EQ(final["progress"]["phase"], "done");
  EXPECT_EQ(final["progress"]["fraction"], 1.0);
  EXPECT_TRUE(final["result"]["measurement_id"].is_number_integer()) << final;
  EXPECT_TRUE(final["result"]["fit_id"].is_number_integer()) << final;
  for (std::size_t i = 0; i + 1 < seen.size(); ++i) EXPECT_NE(seen[i].job["state"], "succeeded");
  EXPECT_EQ(job(blocker)["state"], "cancelled");

  // A finished job: one event, and the stream ends.
  HttpReply reply;
  const auto again = all_events(port(), sample, &reply);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].job, final);
  EXPECT_EQ(reply.header("content-type"), "text/event-stream");
  EXPECT_EQ(reply.header("transfer-encoding"), "chunked");
  EXPECT_EQ(reply.header("cache-control"), "no-cache");
}

TEST_F(JobEventsTest, UnknownJobsAreNotFound) {
  rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), 0));
  ASSERT_NE(port(), 0) << rig_->logs();
  const auto r = follow_events(port(), events_path(999), [](const std::string&) { return true; }, 30s);
  EXPECT_EQ(r.status, 404) << r.error;
  EXPECT_EQ(r.header("content-type"), "application/json");
  EXPECT_EQ(json::parse(r.body, nullptr, false)["error"]["code"], "not_found") << r.body;
  EXPECT_EQ(http_request(port(), "GET", events_path(0)).status, 404);
  EXPECT_EQ(http_request(port(), "POST", events_path(1)).status, 405);
}

TEST_F(JobEventsTest, AClientHangingUpMidStreamDoesNotDisturbTheService) {
  rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), kSlow));
  ASSERT_NE(port(), 0) << rig_->logs();
  const long long session = open_session();
  const long long white = submit(session, {{"kind", "white"}, {"count", 4}});
  // Several followers leave after the first event, while the job runs.
  for (int i = 0; i < 5; ++i) {
    int events = 0;
    const auto r = follow_events(port(), events_path(white), [&](const std::string&) { return ++events < 1; }, 30s);
    EXPECT_EQ(r.status, 200) << r.error;
    EXPECT_EQ(events, 1);
  }
  // One that stays sees the job to its end, and the service goes on answering.
  const auto rest = all_events(port(), white);
  ASSERT_FALSE(rest.empty());
  EXPECT_EQ(rest.back().job["state"], "succeeded") << rest.back().job << rig_->logs();
  EXPECT_EQ(http_request(port(), "GET", "/healthz").status, 200);
  const auto next = all_events(port(), submit(session, {{"kind", "sample"}}));
  ASSERT_FALSE(next.empty());
  EXPECT_EQ(next.back().job["state"], "succeeded") << next.back().job;
}

TEST_F(JobEventsTest, StoppingTheServiceEndsItsStreams) {
  rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), kSlow));
  ASSERT_NE(port(), 0) << rig_->logs();
  const long long job = submit(open_session(), {{"kind", "white"}, {"count", 100}});
  auto stream = follow_in_background(port(), job);
  const auto stopped = rig_->stop_daemon();
  EXPECT_EQ(stopped.exit_status, 0) << stopped.describe();
  // The stream ended with its last chunk, well before the job would have.
  const auto r = stream.get();
  EXPECT_EQ(r.reply.status, 200);
  EXPECT_TRUE(r.reply.error.empty()) << r.reply.error;
  ASSERT_FALSE(r.events.empty());
  const auto state = r.events.back().job["state"].get<std::string>();
  EXPECT_TRUE(state == "queued" || state == "running") << state;
}

}  // namespace
}  // namespace skinspec::testing
