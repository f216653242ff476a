// Named tokens with scopes on a real skinspecd (loopback, --token-file), made and revoked by the
// real `skinspec token`: a read token GETs every GET route and posts nothing, a measure token
// measures but touches no admin route, an admin token does all; a token added or revoked in the
// file takes effect on SIGHUP, from the very next request; a file broken on SIGHUP keeps the old
// tokens; the old two-token file still works, and `skinspec token` converts it; every change is
// in the audit trail once, with its token's name.

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <map>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

using client::http_request;
using client::HttpReply;
using nlohmann::json;
using namespace std::chrono_literals;

const std::string kSkinspec = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec";
const std::string kDaemon = std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd";

ProcessResult skinspec(const std::vector<std::string>& args) {
  return run_process(kSkinspec, args, {.stdin_bytes = {}, .timeout = 30s, .environment = {}});
}

// `skinspec token new NAME --scope SCOPE --file FILE`: the secret it printed.
std::string new_token(const std::string& file, const std::string& name, const std::string& scope) {
  const auto made = skinspec({"token", "new", name, "--scope", scope, "--file", file});
  EXPECT_EQ(made.exit_status, 0) << made.describe();
  std::string secret = made.out;
  while (!secret.empty() && secret.back() == '\n') secret.pop_back();
  EXPECT_EQ(secret.size(), 43u) << made.describe();
  return secret;
}

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A request carrying `token` as its bearer token.
HttpReply as(const std::string& token, unsigned short port, const std::string& method, const std::string& target,
             const std::string& body = "") {
  return http_request(port, method, target, body, {{"Authorization", "Bearer " + token}});
}

void expect_error(const HttpReply& r, int status, const std::string& code) {
  EXPECT_EQ(r.status, status) << r.body << r.error;
  EXPECT_EQ(r.header("content-type"), "application/json") << r.body;
  const json b = r.json();
  ASSERT_TRUE(b.is_object() && b.contains("error")) << r.body;
  EXPECT_EQ(b["error"]["code"], code) << r.body;
}

// The job `accepted` named, once it has ended, asked for with `token`.
json finished_job(const std::string& token, unsigned short port, const HttpReply& accepted) {
  EXPECT_EQ(accepted.status, 202) << accepted.body;
  const std::string path = "/api/v1/jobs/" + std::to_string(accepted.json().value("id", 0LL));
  const auto until = std::chrono::steady_clock::now() + 60s;
  json job;
  do {
    job = as(token, port, "GET", path).json();
    if (job.value("state", "") != "queued" && job.value("state", "") != "running") break;
    std::this_thread::sleep_for(20ms);
  } while (std::chrono::steady_clock::now() < until);
  return job;
}

// Sends SIGHUP and waits for skinspecd to say it has read the token file again, for the `n`th time.
bool hang_up(BackgroundProcess& daemon, int n, const std::string& outcome = "tokens_reloaded") {
  daemon.send_signal(SIGHUP);
  return daemon.wait_for_stderr("event=" + outcome + " reload=" + std::to_string(n) + " ", 20s);
}

const std::string kSession = json{{"site", "forearm"}, {"subject", "S"}}.dump();
const std::string kWhiteStandard =
    json{{"name", "PTFE"}, {"wavelength_nm", {380, 780}}, {"reflectance", {0.99, 0.98}}}.dump();

class TokensProcessTest : public ::testing::Test {
 protected:
  ScratchDirectory dir_;
  std::string file_ = dir_.file("tokens.json");
};

TEST_F(TokensProcessTest, EachScopeDoesWhatItMayAndSighupAddsAndRevokes) {
  const std::string viewer = new_token(file_, "viewer", "read");
  const std::string ana = new_token(file_, "ana", "measure");
  const std::string lab = new_token(file_, "lab", "admin");
  // The file is private and holds no secret.
  struct stat st{};
  ASSERT_EQ(::stat(file_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  for (const auto& secret : {viewer, ana, lab}) EXPECT_EQ(file_text(file_).find(secret), std::string::npos);
  const auto again = skinspec({"token", "new", "ana", "--scope", "admin", "--file", file_});
  EXPECT_EQ(again.exit_status, 2) << again.describe();
  EXPECT_NE(again.err.find("a token named 'ana' exists already"), std::string::npos) << again.err;
  const auto listed = skinspec({"token", "list", "--file", file_});
  ASSERT_EQ(listed.exit_status, 0) << listed.describe();
  EXPECT_EQ(lines_of(listed.out).size(), 4u) << listed.out;
  EXPECT_NE(listed.out.find("ana                      measure"), std::string::npos) << listed.out;

  AcquisitionRig rig(rig_options(dir_.path().string(), {}, {"--token-file", file_}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;
  EXPECT_EQ(http_request(p, "GET", "/healthz").status, 200);
  expect_error(http_request(p, "GET", "/api/v1/sessions"), 401, "unauthorized");
  expect_error(as("not-a-token", p, "GET", "/api/v1/sessions"), 401, "unauthorized");

  // measure: a session and a white and a sample measured in it; no white standard stored.
  const auto session = as(ana, p, "POST", "/api/v1/sessions", kSession);
  ASSERT_EQ(session.status, 201) << session.body;
  const std::string sessions = "/api/v1/sessions/" + std::to_string(session.json()["id"].get<long long>());
  const json white = finished_job(ana, p, as(ana, p, "POST", sessions + "/measurements", R"({"kind": "white"})"));
  ASSERT_EQ(white["state"], "succeeded") << white;
  const json sample = finished_job(ana, p, as(ana, p, "POST", sessions + "/measurements", R"({"kind": "sample"})"));
  ASSERT_EQ(sample["state"], "succeeded") << sample;
  const auto forbidden = as(ana, p, "POST", "/api/v1/white-standards", kWhiteStandard);
  expect_error(forbidden, 403, "forbidden");
  EXPECT_EQ(forbidden.json()["error"]["message"],
            "POST /api/v1/white-standards needs a token of scope admin; 'ana' has scope measure");

  // admin: everything.
  const auto ws = as(lab, p, "POST", "/api/v1/white-standards", kWhiteStandard);
  ASSERT_EQ(ws.status, 201) << ws.body;
  EXPECT_EQ(as(lab, p, "PATCH", sessions, R"({"notes": "by the admin"})").status, 200);
  const auto refitted =
      as(lab, p, "POST",
         "/api/v1/measurements/" + std::to_string(sample["result"]["measurement_id"].get<long long>()) + "/fit", "{}");
  EXPECT_EQ(refitted.status, 201) << refitted.body;
  const json by_admin = finished_job(lab, p, as(lab, p, "POST", sessions + "/measurements", R"({"kind": "sample"})"));
  EXPECT_EQ(by_admin["state"], "succeeded") << by_admin;
  // Cancelling an ended job is a conflict, not a refusal of the token.
  EXPECT_EQ(as(lab, p, "DELETE", "/api/v1/jobs/" + std::to_string(by_admin["id"].get<long long>())).status, 409);

  // read: every GET route of the OpenAPI document, with the records made above; nothing else.
  const json doc = as(viewer, p, "GET", "/openapi.json").json();
  ASSERT_TRUE(doc.contains("paths")) << doc;
  const std::map<std::string, long long> ids = {
      {"/api/v1/sessions/", session.json()["id"]},   {"/api/v1/measurements/", sample["result"]["measurement_id"]},
      {"/api/v1/fits/", sample["result"]["fit_id"]}, {"/api/v1/jobs/", sample["id"]},
      {"/api/v1/white-standards/", ws.json()["id"]}, {"/api/v1/maps/", 1},  // none made: 404, from the route itself
  };
  int gets = 0;
  for (const auto& [path, operations] : doc["paths"].items()) {
    if (!operations.contains("get")) continue;
    std::string target = path;
    if (const auto at = target.find("{id}"); at != std::string::npos) {
      long long id = 0;
      for (const auto& [prefix, value] : ids)
        if (target.starts_with(prefix)) id = value;
      ASSERT_NE(id, 0) << path;
      target.replace(at, 4, std::to_string(id));
    }
    if (const auto at = target.find("{parameter}"); at != std::string::npos) target.replace(at, 11, "melanin");
    if (target.ends_with("/pixel")) target += "?x=0&y=0";
    const auto r = as(viewer, p, "GET", target);
    ++gets;
    // The audit trail is the one GET for admins alone: it names who did what.
    const int expected = target.starts_with("/api/v1/audit") ? 403 : target.starts_with("/api/v1/maps/") ? 404 : 200;
    EXPECT_EQ(r.status, expected) << target << ": " << r.body;
  }
  EXPECT_GE(gets, 25);
  expect_error(as(viewer, p, "POST", "/api/v1/sessions", kSession), 403, "forbidden");
  expect_error(as(viewer, p, "POST", sessions + "/measurements", R"({"kind": "white"})"), 403, "forbidden");
  expect_error(as(viewer, p, "DELETE", "/api/v1/jobs/" + std::to_string(sample["id"].get<long long>())), 403,
               "forbidden");

  // A token added: unknown until SIGHUP, known from then on.
  const std::string bo = new_token(file_, "bo", "measure");
  expect_error(as(bo, p, "GET", "/api/v1/sessions"), 401, "unauthorized");
  ASSERT_TRUE(hang_up(*rig.daemon, 1)) << rig.logs();
  EXPECT_EQ(as(bo, p, "GET", "/api/v1/sessions").status, 200);
  EXPECT_EQ(as(bo, p, "POST", "/api/v1/sessions", kSession).status, 201);

  // A token revoked: refused on the very next request after SIGHUP.
  EXPECT_EQ(as(ana, p, "GET", "/api/v1/sessions").status, 200);
  const auto revoked = skinspec({"token", "revoke", "ana", "--file", file_});
  ASSERT_EQ(revoked.exit_status, 0) << revoked.describe();
  ASSERT_TRUE(hang_up(*rig.daemon, 2)) << rig.logs();
  expect_error(as(ana, p, "GET", "/api/v1/sessions"), 401, "unauthorized");
  expect_error(as(ana, p, "POST", "/api/v1/sessions", kSession), 401, "unauthorized");
  EXPECT_EQ(skinspec({"token", "revoke", "ana", "--file", file_}).exit_status, 2);

  // A file broken, or open to others, on SIGHUP: logged, and the tokens stay as they were;
  // the service neither stops nor opens to everyone.
  const std::string good = file_text(file_);
  std::ofstream(file_, std::ios::trunc) << R"({"tokens": [{"name": "bo", "scope": "root"}]})";
  ASSERT_TRUE(hang_up(*rig.daemon, 3, "token_reload_failed")) << rig.logs();
  EXPECT_NE(rig.daemon->err().find("tokens_kept=3"), std::string::npos) << rig.logs();
  EXPECT_NE(rig.daemon->err().find(file_ + ": tokens[0] ('bo'): 'scope' must be read, measure or admin"),
            std::string::npos)
      << rig.logs();
  std::ofstream(file_, std::ios::trunc) << good;
  ::chmod(file_.c_str(), 0644);
  ASSERT_TRUE(hang_up(*rig.daemon, 4, "token_reload_failed")) << rig.logs();
  EXPECT_FALSE(rig.daemon->has_exited());
  EXPECT_EQ(as(bo, p, "GET", "/api/v1/sessions").status, 200);
  EXPECT_EQ(as(lab, p, "POST", "/api/v1/white-standards", kWhiteStandard).status, 201);
  expect_error(as(ana, p, "GET", "/api/v1/sessions"), 401, "unauthorized");
  expect_error(http_request(p, "GET", "/api/v1/sessions"), 401, "unauthorized");
}

// Each change made through the service appears once in the audit trail, with its token's name
// and address; a request whose change was rolled back does not; only an admin token reads it.
TEST_F(TokensProcessTest, EachChangeIsInTheAuditTrailOnceWithItsTokensName) {
  const std::string viewer = new_token(file_, "viewer", "read");
  const std::string ana = new_token(file_, "ana", "measure");
  const std::string lab = new_token(file_, "lab", "admin");
  AcquisitionRig rig(rig_options(dir_.path().string(), {}, {"--token-file", file_}));
  ASSERT_TRUE(rig.ready()) << rig.logs();
  const auto p = rig.port;

  const auto session = as(ana, p, "POST", "/api/v1/sessions", kSession);
  ASSERT_EQ(session.status, 201) << session.body;
  const std::string sessions = "/api/v1/sessions/" + std::to_string(session.json()["id"].get<long long>());
  const json white = finished_job(ana, p, as(ana, p, "POST", sessions + "/measurements", R"({"kind": "white"})"));
  ASSERT_EQ(white["state"], "succeeded") << white;
  EXPECT_EQ(as(lab, p, "PATCH", sessions, R"({"notes": "by the admin"})").status, 200);
  ASSERT_EQ(as(lab, p, "POST", "/api/v1/white-standards", kWhiteStandard).status, 201);
  // Refused inside the store, so rolled back: no entry.
  expect_error(as(lab, p, "PATCH", "/api/v1/sessions/9999", R"({"notes": "none"})"), 404, "not_found");

  expect_error(as(ana, p, "GET", "/api/v1/audit"), 403, "forbidden");
  expect_error(as(viewer, p, "GET", "/api/v1/audit"), 403, "forbidden");
  const auto trail = as(lab, p, "GET", "/api/v1/audit");
  ASSERT_EQ(trail.status, 200) << trail.body;
  const json body = trail.json();
  std::vector<std::string> seen;
  for (const auto& e : body["entries"]) {
    EXPECT_EQ(e["address"], "127.0.0.1") << e;
    seen.push_back(e["token"].get<std::string>() + " | " + e["request"].get<std::string>() + " | " +
                   e["change"].get<std::string>());
  }
  const std::string id = sessions.substr(sessions.rfind('/') + 1);
  EXPECT_EQ(seen, (std::vector<std::string>{
                      "lab | POST /api/v1/white-standards | storing a white standard",
                      "lab | PATCH " + sessions + " | updating session " + id,
                      "ana | POST " + sessions + "/measurements | creating a job",
                      "ana | POST /api/v1/sessions | creating a session",
                  }))
      << trail.body;
  const auto page = as(lab, p, "GET", "/api/v1/audit?limit=1");
  EXPECT_EQ(page.json()["entries"].size(), 1u) << page.body;
  EXPECT_TRUE(page.json()["next_before"].is_number_integer()) << page.body;

  // The whole trail to download, oldest first, exactly as `skinspec export --audit` writes it.
  for (const std::string format : {"csv", "jsonl"}) {
    const std::string target = "/api/v1/audit/export." + format;
    expect_error(as(ana, p, "GET", target), 403, "forbidden");
    const auto exported = as(lab, p, "GET", target);
    ASSERT_EQ(exported.status, 200) << target << ": " << exported.body;
    const auto cli =
        skinspec({"export", "--db", rig.db_path(), "--audit", "--format", format == "csv" ? "csv" : "json"});
    ASSERT_EQ(cli.exit_status, 0) << cli.describe();
    EXPECT_EQ(exported.body, cli.out) << target;
  }
  const auto lines = as(lab, p, "GET", "/api/v1/audit/export.jsonl").body;
  EXPECT_EQ(std::ranges::count(lines, '\n'), 4) << lines;
  EXPECT_EQ(json::parse(lines.substr(0, lines.find('\n')))["request"], "POST /api/v1/sessions") << lines;
}

TEST_F(TokensProcessTest, TheOldTwoTokenFileStillWorksAndIsConverted) {
  std::ofstream(file_) << R"({"read_token": "read-0123456789abcdef", "operator_token": "oper-0123456789abcdef"})";
  ::chmod(file_.c_str(), 0600);
  BackgroundProcess d(kDaemon, {"--listen", "127.0.0.1:0", "--db", dir_.file("t.db"), "--token-file", file_});
  const auto line = d.wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
  ASSERT_TRUE(line) << d.err();
  const auto p = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
  const std::string read = "read-0123456789abcdef", oper = "oper-0123456789abcdef";
  const auto check = [&] {
    EXPECT_EQ(as(read, p, "GET", "/api/v1/sessions").status, 200);
    expect_error(as(read, p, "POST", "/api/v1/sessions", kSession), 403, "forbidden");
    // The old operator token could do everything, the white standards too.
    EXPECT_EQ(as(oper, p, "POST", "/api/v1/sessions", kSession).status, 201);
    EXPECT_EQ(as(oper, p, "POST", "/api/v1/white-standards", kWhiteStandard).status, 201);
  };
  check();

  // A named token added to it: the file is written with hashes only, the old tokens kept.
  const std::string ana = new_token(file_, "ana", "measure");
  const std::string text = file_text(file_);
  EXPECT_EQ(text.find(read), std::string::npos) << text;
  EXPECT_EQ(text.find(oper), std::string::npos) << text;
  ASSERT_TRUE(hang_up(d, 1)) << d.err();
  check();
  EXPECT_EQ(as(ana, p, "POST", "/api/v1/sessions", kSession).status, 201);
  const auto listed = skinspec({"token", "list", "--file", file_});
  EXPECT_NE(listed.out.find("operator                 admin"), std::string::npos) << listed.describe();
  // Clients cannot take a secret out of it any more, and say so.
  const auto client =
      skinspec({"session", "list", "--server", "http://127.0.0.1:" + std::to_string(p), "--token-file", file_});
  EXPECT_EQ(client.exit_status, 2) << client.describe();
  EXPECT_NE(client.err.find("holds only their hashes"), std::string::npos) << client.err;
  d.send_signal(SIGTERM);
  EXPECT_EQ(d.wait(30s).exit_status, 0);
}

// On loopback without --token-file nothing is asked, as before; SIGHUP changes nothing there.
TEST_F(TokensProcessTest, WithoutATokenFileSighupChangesNothing) {
  BackgroundProcess d(kDaemon, {"--listen", "127.0.0.1:0", "--db", dir_.file("t.db")});
  const auto line = d.wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
  ASSERT_TRUE(line) << d.err();
  const auto p = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
  EXPECT_EQ(http_request(p, "POST", "/api/v1/white-standards", kWhiteStandard).status, 201);
  ASSERT_TRUE(hang_up(d, 1, "nothing_reloaded")) << d.err();
  EXPECT_EQ(http_request(p, "POST", "/api/v1/sessions", kSession).status, 201);
  d.send_signal(SIGTERM);
  EXPECT_EQ(d.wait(30s).exit_status, 0);
}

}  // namespace
}  // namespace skinspec::testing
