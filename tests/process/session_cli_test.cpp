// `skinspec session new|measure|show|list` against a real skinspecd driving skinspec-sim: what
// it prints, its exit statuses, and the fitted parameters equal to the service's stored fit.

#include <gmock/gmock.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <sstream>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/client/http_client.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using ::testing::EndsWith;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

class SessionCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), 0));
    ASSERT_NE(rig_->port, 0) << rig_->logs();
  }
  // The test's standard error is a pipe: the plain, line-per-event progress.
  ProcessResult skinspec(std::vector<std::string> args) const {
    args.insert(args.end(), {"--server", rig_->url()});
    return run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args, ProcessOptions{std::nullopt, 120s, {}});
  }
  long long new_session() const {
    const auto r = skinspec({"session", "new", "--site", "forearm", "--subject", "C1", "--operator", "op", "--json"});
    EXPECT_EQ(r.exit_status, 0) << r.describe();
    return json::parse(r.out, nullptr, false).value("id", 0LL);
  }

  ScratchDirectory dir_;
  std::unique_ptr<AcquisitionRig> rig_;
};

// "  melanin   13.6003 ± 0.157974" → 13.6003, for the parameter `name`.
std::optional<double> printed_value(const std::string& out, const std::string& name) {
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string first;
    double value = 0;
    if (words >> first && first == name && words >> value) return value;
  }
  return std::nullopt;
}

TEST_F(SessionCliTest, NewMeasureShowAndListASession) {
  const auto created = skinspec({"session", "new", "--site", "forearm", "--subject", "V7", "--notes", "left arm"});
  ASSERT_EQ(created.exit_status, 0) << created.describe();
  EXPECT_NE(created.out.find("session 1 opened: site forearm, subject V7"), std::string::npos) << created.out;
  EXPECT_NE(created.out.find(rig_->url() + "/api/v1/sessions/1"), std::string::npos) << created.out;

  const auto white = skinspec({"session", "measure", "1", "--kind", "white", "--label", "PTFE"});
  ASSERT_EQ(white.exit_status, 0) << white.describe() << rig_->logs();
  EXPECT_NE(white.out.find("succeeded: measurement 1"), std::string::npos) << white.out;

  const auto sample = skinspec({"session", "measure", "1", "--kind", "sample", "--count", "3"});
  ASSERT_EQ(sample.exit_status, 0) << sample.describe() << rig_->logs();
  // Not a terminal: one line per event, never a carriage return.
  EXPECT_EQ(sample.err.find('\r'), std::string::npos);
  EXPECT_EQ(sample.out.find('\r'), std::string::npos);
  std::istringstream progress(sample.err);
  for (std::string line; std::getline(progress, line);) EXPECT_EQ(line.rfind("job 2: ", 0), 0u) << line;
  EXPECT_NE(sample.err.find("job 2: succeeded, done 3/3"), std::string::npos) << sample.err;
  EXPECT_NE(sample.out.find("job 2 succeeded: measurement 2 (white 1), fit 1"), std::string::npos) << sample.out;

  const json fit = http_request(rig_->port, "GET", "/api/v1/fits/1").json();
  EXPECT_NE(sample.out.find("model extended"), std::string::npos) << sample.out;
  ASSERT_EQ(fit["params"].size(), 7u) << fit;
  for (const auto& [name, stored] : fit["params"].items()) {
    const auto line = sample.out.find("  " + name + " ");
    ASSERT_NE(line, std::string::npos) << name << " missing from\n" << sample.out;
    const auto end = sample.out.find('\n', line);
    if (!fit["determination"][name]["determined"].get<bool>()) {
      // Never a number for what the spectrum did not determine: "n.d." and the reason.
      EXPECT_EQ(
          sample.out.substr(line, end - line).find("n.d. (" + fit["determination"][name]["reason"].get<std::string>()),
          sample.out.substr(line, end - line).find("n.d."))
          << sample.out;
      EXPECT_FALSE(printed_value(sample.out, name)) << name;
      continue;
    }
    const auto value = printed_value(sample.out, name);
    ASSERT_TRUE(value) << name << " missing from\n" << sample.out;
    EXPECT_NEAR(*value, stored.get<double>(), 1e-5 * std::abs(stored.get<double>())) << name;
    EXPECT_NE(sample.out.substr(line, end - line).find("± "), std::string::npos) << name << ": no standard error";
  }
  // Each parameter with its unit, from the model's table.
  const auto melanin = sample.out.find("  melanin ");
  ASSERT_NE(melanin, std::string::npos) << sample.out;
  EXPECT_THAT(sample.out.substr(melanin, sample.out.find('\n', melanin) - melanin),
              EndsWith("  [x 1 % melanosomes in the epidermis]"));
  EXPECT_THAT(sample.out, HasSubstr(" [reflectance, as a fraction]   dE2000 (D65) "));
  EXPECT_TRUE(printed_value(sample.out, "rmse")) << sample.out;
  EXPECT_NEAR(*printed_value(sample.out, "rmse"), fit["rmse"].get<double>(), 1e-5 * fit["rmse"].get<double>());
  EXPECT_NE(sample.out.find("dE2000"), std::string::npos);

  const auto show = skinspec({"session", "show", "1"});
  ASSERT_EQ(show.exit_status, 0) << show.describe();
  EXPECT_NE(show.out.find("subject V7"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("notes: left arm"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("PTFE"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("model extended"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("fits, model extended"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("dermis_scattering_power"), std::string::npos) << show.out;
  // The fits' table: its units above, what "n.d." means below.
  EXPECT_THAT(show.out, HasSubstr("fits, model extended\nunits: surface_reflectance [fraction]; melanin [x 1 % "
                                  "melanosomes in the epidermis]; "));
  EXPECT_THAT(show.out, HasSubstr("; rmse [reflectance, as a fraction]; dE2000 [CIEDE2000 of measured and fitted "
                                  "colour under D65]; ITA° [degrees]; M, E [100 log10 of a reflectance ratio "
                                  "(Diffey 1984)]\n"));
  // The fit's skin tone, as the service stored it, in its row.
  const auto stored = json::parse(skinspec({"session", "show", "1", "--json"}).out, nullptr, false)["fits"][0];
  ASSERT_TRUE(stored.contains("skin_tone")) << stored;
  EXPECT_THAT(show.out, HasSubstr(fmt::format(" {:>5.1f} {:<12} ", stored["skin_tone"]["ita_deg"].get<double>(),
                                              stored["skin_tone"]["ita_class"].get<std::string>())));
  EXPECT_THAT(show.out, EndsWith("n.d.: not determined by this spectrum (reason in --json; docs/model.md, \"What "
                                 "the spectrum determines\")\n"));
  const auto shown = json::parse(skinspec({"session", "show", "1", "--json"}).out, nullptr, false);
  EXPECT_EQ(shown["measurements"].size(), 2u) << shown;
  EXPECT_EQ(shown["fits"].size(), 1u);

  new_session();
  const auto list = skinspec({"session", "list", "--site", "forearm", "--limit", "1", "--json"});
  ASSERT_EQ(list.exit_status, 0) << list.describe();
  const json page = json::parse(list.out, nullptr, false);
  ASSERT_EQ(page["sessions"].size(), 1u) << list.out;
  EXPECT_EQ(page["sessions"][0]["subject"], "C1");  // newest first
  const auto table = skinspec({"session", "list", "--state", "open"});
  EXPECT_NE(table.out.find("V7"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("C1"), std::string::npos) << table.out;
}

TEST_F(SessionCliTest, JsonOutputCarriesTheJobAndItsFit) {
  const long long session = new_session();
  const std::string id = std::to_string(session);
  ASSERT_EQ(skinspec({"session", "measure", id, "--kind", "white"}).exit_status, 0);
  const auto r = skinspec({"session", "measure", id, "--kind", "sample", "--json"});
  ASSERT_EQ(r.exit_status, 0) << r.describe();
  const json out = json::parse(r.out, nullptr, false);
  ASSERT_TRUE(out.is_object()) << r.out;
  EXPECT_EQ(out["job"]["state"], "succeeded");
  const auto fit =
      http_request(rig_->port, "GET", "/api/v1/fits/" + std::to_string(out["job"]["result"]["fit_id"].get<long long>()))
          .json();
  EXPECT_EQ(out["fit"], fit);

  const auto queued = skinspec({"session", "measure", id, "--kind", "white", "--no-wait", "--json"});
  ASSERT_EQ(queued.exit_status, 0) << queued.describe();
  EXPECT_TRUE(json::parse(queued.out, nullptr, false)["id"].is_number_integer()) << queued.out;
}

TEST_F(SessionCliTest, AFailedJobExitsWith3) {
  const long long session = new_session();
  // A sample without a white reference fails.
  const auto r = skinspec({"session", "measure", std::to_string(session), "--kind", "sample"});
  EXPECT_EQ(r.exit_status, 3) << r.describe();
  EXPECT_NE(
      r.err.find("failed: measure the white standard of session " + std::to_string(session) + " first (no_white)"),
      std::string::npos)
      << r.err;
}

TEST_F(SessionCliTest, RefusedRequestsExitWith2AndTheServersMessage) {
  const auto missing = skinspec({"session", "show", "42"});
  EXPECT_EQ(missing.exit_status, 2) << missing.describe();
  EXPECT_NE(missing.err.find("404"), std::string::npos) << missing.err;
  EXPECT_NE(missing.err.find("session 42 does not exist"), std::string::npos) << missing.err;
  const auto measure = skinspec({"session", "measure", "42", "--kind", "white"});
  EXPECT_EQ(measure.exit_status, 2) << measure.describe();
  const auto site = skinspec({"session", "new", "--site", "elbow"});
  EXPECT_EQ(site.exit_status, 2) << site.describe();
  EXPECT_NE(site.err.find("unknown_site"), std::string::npos) << site.err;
  const auto kind = skinspec({"session", "measure", "1", "--kind", "dark"});
  EXPECT_EQ(kind.exit_status, 2) << kind.describe();
}

TEST_F(SessionCliTest, AnUnreachableServerExitsWith4) {
  // A port nothing listens on: the daemon's, once it has stopped.
  const std::string url = rig_->url();
  rig_.reset();
  const auto r = run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"session", "list", "--server", url},
                             ProcessOptions{std::nullopt, 60s, {}});
  EXPECT_EQ(r.exit_status, 4) << r.describe();
  EXPECT_NE(r.err.find("cannot reach skinspecd at " + url), std::string::npos) << r.err;
  const auto bad = run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"session", "list", "--server", "ftp://x"},
                               ProcessOptions{std::nullopt, 60s, {}});
  EXPECT_EQ(bad.exit_status, 2) << bad.describe();
}

}  // namespace
}  // namespace skinspec::testing
