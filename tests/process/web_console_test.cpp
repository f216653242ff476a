// The web console in a real headless Chromium, against real skinspecd and skinspec-sim
// processes on loopback: a whole session clicked through, the plotted values checked against
// what the API returns, and a screenshot of each screen kept as a test artefact.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <thread>

#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "support/webdriver.hpp"

namespace skinspec::testing {
namespace {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

const std::string kData = SKINSPEC_TEST_DATA_DIR;
const std::string kArtifacts = SKINSPEC_TEST_ARTIFACT_DIR;

class WebConsoleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!Browser::available())
      GTEST_SKIP() << "needs Debian's chromium and chromium-driver (scripts/setup installs them)";
    // A little meter time per reading, so that a long job can be watched and cancelled.
    RigOptions options = rig_options(dir_.path().string(),
                                     {"--time-scale", "0.02", "--white", kData + "/examples/white-standard.csv",
                                      "--reflectance", kData + "/examples/forearm.csv", "--illuminant", "A"},
                                     {"--log-level", "warn"});
    options.default_scenes = false;
    options.sim_args.insert(options.sim_args.end(), meter_.begin(), meter_.end());
    rig_ = std::make_unique<AcquisitionRig>(std::move(options));
    ASSERT_TRUE(rig_->ready()) << rig_->logs();
    port_ = rig_->port;
    browser_ = std::make_unique<Browser>(dir_.file("chromium-profile"), 1400, 2000);  // tall enough for whole screens
    ASSERT_TRUE(browser_->ready());
  }
  void TearDown() override {
    browser_.reset();
    rig_.reset();
  }

  std::string url(const std::string& hash) const { return "http://127.0.0.1:" + std::to_string(port_) + "/" + hash; }
  json get(const std::string& path) const { return get_json(port_, path); }
  void shot(const std::string& name) { EXPECT_TRUE(browser_->screenshot(kArtifacts + "/" + name)) << name; }
  // The numbers a plotted series was drawn from.
  std::vector<double> plotted(const std::string& plot, const std::string& series) {
    const json v =
        browser_->run("const p = document.querySelector(arguments[0]); return p ? JSON.parse(p.dataset.y) : null;",
                      json::array({"#" + plot + " path[data-series='" + series + "']"}));
    return v.is_array() ? v.get<std::vector<double>>() : std::vector<double>{};
  }
  // Waits for the job box to show an ended job; its state.
  std::string job_end_state() {
    const bool ended = browser_->wait_until(
        "const j = document.getElementById('job'); return !!j && "
        "['succeeded','failed','cancelled','refused'].includes(j.dataset.state);",
        60s);
    if (!ended) return "still running";
    return browser_->run("return document.getElementById('job').dataset.state;").get<std::string>();
  }

  // A new session's screen once skinspecd has identified the meter, showing `ready` (a CSS
  // selector); false, with a failure saying why, when the meter was never connected.
  bool new_session_screen_with(const std::string& ready) {
    std::string state;
    for (auto until = std::chrono::steady_clock::now() + 30s; std::chrono::steady_clock::now() < until;) {
      state = get("/api/v1/instrument").value("state", "");
      if (state == "connected") break;
      std::this_thread::sleep_for(50ms);
    }
    if (state != "connected") {
      ADD_FAILURE() << "the meter is " << state << ": " << rig_->logs();
      return false;
    }
    const auto created = http_request(port_, "POST", "/api/v1/sessions", R"({"site": "forearm", "subject": "v"})");
    if (created.status != 201) {
      ADD_FAILURE() << created.body;
      return false;
    }
    browser_->open(url("#/sessions/1"));
    browser_->find(ready);
    return true;
  }

  std::vector<std::string> meter_;  // skinspec-sim's model, for fixtures of another meter
  ScratchDirectory dir_;
  std::unique_ptr<AcquisitionRig> rig_;
  std::unique_ptr<Browser> browser_;
  unsigned short port_ = 0;
};

void expect_same(const std::vector<double>& shown, const std::vector<double>& api, const std::string& what) {
  ASSERT_EQ(shown.size(), api.size()) << what;
  ASSERT_FALSE(api.empty()) << what;
  for (std::size_t i = 0; i < api.size(); ++i)
    EXPECT_NEAR(shown[i], api[i], 1e-12 * (1 + std::abs(api[i]))) << what << " at " << i;
}

TEST_F(WebConsoleTest, AWholeSessionClickedThroughShowsWhatTheApiHolds) {
  // Sessions screen: a new session through the form.
  browser_->open(url("#/sessions"));
  browser_->find("#new-session");
  shot("01-sessions.png");
  browser_->run("document.querySelector('#new-session [name=site]').value = 'forearm';");
  browser_->type(browser_->find("#new-session [name=subject]"), "volunteer-7");
  browser_->type(browser_->find("#new-session [name=operator]"), "bench operator");
  browser_->click(browser_->find("#new-session button[type=submit]"));
  ASSERT_TRUE(browser_->wait_until("return location.hash === '#/sessions/1';"))
      << browser_->run("return location.hash;");
  const json session = get("/api/v1/sessions/1");
  EXPECT_EQ(session["subject"], "volunteer-7");
  EXPECT_EQ(session["operator"], "bench operator");

  // Acquisition: W from the keyboard measures the white; then three readings of the skin.
  browser_->find("#measure-white");
  browser_->run("document.activeElement.blur();");
  browser_->type(browser_->find("body"), "w");
  EXPECT_EQ(job_end_state(), "succeeded");
  ASSERT_TRUE(browser_->wait_until("return !!document.querySelector(\"#measurements tr[data-measurement='1']\");"));
  EXPECT_TRUE(browser_->wait_until("return document.getElementById('instrument-state').textContent === 'connected';"))
      << browser_->run("return document.getElementById('instrument').textContent;");
  const json instrument = get("/api/v1/instrument");
  EXPECT_EQ(instrument["state"], "connected");
  // The meter as it named itself, and its serial number.
  EXPECT_EQ(instrument["reported_model"], "PR-650");
  EXPECT_EQ(browser_->run("return document.getElementById('instrument-model').textContent;"),
            instrument["reported_model"]);
  EXPECT_EQ(browser_->run("return document.getElementById('instrument-serial').textContent;"),
            "S/N " + instrument["serial_number"].get<std::string>());
  browser_->run(
      "document.getElementById('count').value = '3'; document.getElementById('label').value = 'left forearm';");
  browser_->click(browser_->find("#measure-sample"));
  EXPECT_EQ(job_end_state(), "succeeded");
  const json job =
      get("/api/v1/jobs/" + browser_->run("return document.getElementById('job').dataset.job;").get<std::string>());
  EXPECT_EQ(job["state"], "succeeded");
  EXPECT_NE(browser_->text(browser_->find("#job-status"))
                .find("measurement #" + std::to_string(job["result"]["measurement_id"].get<long long>())),
            std::string::npos);
  shot("02-acquisition.png");
  // The melanin, RMSE and ΔE2000 columns say their units, those of the session's model.
  const json known = get("/api/v1/models");
  json session_model;
  for (const auto& candidate : known["models"])
    if (candidate["name"] == session["model"]) session_model = candidate;
  ASSERT_TRUE(session_model.is_object()) << session["model"];
  const json melanin = session_model["params"][1];
  ASSERT_EQ(melanin["name"], "melanin");
  const auto column_text = [&](const std::string& label) {
    const json t = browser_->run(
        "const th = [...document.querySelectorAll('#measurements thead th')]"
        ".find((e) => e.firstChild && e.firstChild.textContent === arguments[0]); return th ? th.textContent : null;",
        json::array({label}));
    return t.is_string() ? t.get<std::string>() : std::string("(no column " + label + ")");
  };
  EXPECT_EQ(column_text(melanin["label"]), melanin["label"].get<std::string>() + melanin["unit"].get<std::string>());
  ASSERT_EQ(session_model["fit_quality"].size(), 2u);
  for (const auto& q : session_model["fit_quality"])
    EXPECT_EQ(column_text(q["label"]), q["label"].get<std::string>() + q["unit"].get<std::string>()) << q;
  // The session reloads to list the new measurement; the next click goes to the new screen.
  ASSERT_TRUE(browser_->wait_until("return !!document.querySelector(\"#measurements tr[data-measurement='" +
                                   std::to_string(job["result"]["measurement_id"].get<long long>()) + "']\");"));

  // A long job cancelled from the keyboard.
  browser_->run("document.getElementById('count').value = '100';");
  browser_->click(browser_->find("#measure-sample"));
  ASSERT_TRUE(
      browser_->wait_until("const j = document.getElementById('job'); return !!j.dataset.job && j.dataset.job !== '" +
                           std::to_string(job["id"].get<long long>()) + "';"));
  browser_->run("document.activeElement.blur();");
  browser_->type(browser_->find("body"), "\xEE\x80\x8C");  // WebDriver's Escape key
  EXPECT_EQ(job_end_state(), "cancelled");
  EXPECT_NE(browser_->text(browser_->find("#job-status")).find("(cancelled: cancelled by request)"), std::string::npos)
      << browser_->text(browser_->find("#job-status"));
  shot("03-cancelled.png");

  // The measurement: every plotted number is the API's.
  const long long sample = job["result"]["measurement_id"].get<long long>();
  browser_->open(url("#/measurements/" + std::to_string(sample)));
  browser_->find("#fit-params");
  const json m = get("/api/v1/measurements/" + std::to_string(sample));
  const json fit = get("/api/v1/fits/" + std::to_string(m["fit_id"].get<long long>()));
  expect_same(plotted("plot-radiance", "radiance"), m["radiance"]["values"].get<std::vector<double>>(), "radiance");
  expect_same(plotted("plot-reflectance", "measured"), m["reflectance"]["values"].get<std::vector<double>>(),
              "reflectance");
  expect_same(plotted("plot-reflectance", "fitted"), fit["fitted"].get<std::vector<double>>(), "fitted curve");
  std::vector<double> residuals;
  for (std::size_t i = 0; i < fit["fitted"].size(); ++i)
    residuals.push_back(fit["measured"][i].get<double>() - fit["fitted"][i].get<double>());
  expect_same(plotted("plot-residuals", "residual"), residuals, "residuals");
  ASSERT_FALSE(fit["params"].empty());
  for (const auto& [p, stored] : fit["params"].items()) {
    const std::string shown =
        browser_->text(browser_->find(std::string("#fit-params tr[data-param='") + p + "'] td.value"));
    // What the spectrum did not determine shows no number.
    if (!fit["determination"][p]["determined"].get<bool>()) {
      EXPECT_EQ(shown, "n.d.") << p;
      continue;
    }
    const double value = stored.get<double>();
    EXPECT_NEAR(std::stod(shown), value, 1e-3 * std::abs(value) + 1e-9) << p;
  }
  EXPECT_NEAR(std::stod(browser_->text(browser_->find("#fit-params tr[data-param='rmse'] td.value"))),
              fit["rmse"].get<double>(), 1e-2 * fit["rmse"].get<double>());
  EXPECT_NEAR(std::stod(browser_->text(browser_->find("#fit-params tr[data-param='delta_e00_d65'] td.value"))),
              fit["delta_e00_d65"].get<double>(), 1e-2 * fit["delta_e00_d65"].get<double>());
  for (const char* light : {"D65", "A"}) {
    const auto rgb = m["colour"][light]["srgb"];
    const std::string expected = std::to_string(rgb[0].get<int>()) + "," + std::to_string(rgb[1].get<int>()) + "," +
                                 std::to_string(rgb[2].get<int>());
    EXPECT_EQ(browser_->run("return document.querySelector(arguments[0]).dataset.srgb;",
                            json::array({std::string(".chip[data-illuminant='") + light + "']"})),
              expected)
        << light;
  }
  shot("04-measurement.png");

  // The rendered hand, re-rendered with four times the melanin.
  ASSERT_TRUE(browser_->wait_until(
      "const i = document.getElementById('render'); return i.complete && i.naturalWidth > 0;", 60s))
      << browser_->run("return document.getElementById('render-status').textContent;");
  browser_->run(
      "const s = document.getElementById('scale-melanin'); s.value = '4'; s.dispatchEvent(new Event('change'));");
  EXPECT_TRUE(browser_->wait_until(
      "return (document.getElementById('render').dataset.query || '').includes('scale_melanin=4');", 60s))
      << browser_->run(
             "return document.getElementById('render-status').textContent + ' ' + "
             "document.getElementById('render').dataset.query;");
  // The extended fit's own parameters, as GET /api/v1/models describes them: a slider each (an
  // amount scaled, anything else set), none for the paper's oxy- and deoxy-haemoglobin, and the
  // unit of each in its slider's label and in the fit's table.
  ASSERT_EQ(fit["model"], "extended");
  const json models = get("/api/v1/models");
  json model;
  for (const auto& candidate : models["models"])
    if (candidate["name"] == fit["model"]) model = candidate;
  ASSERT_TRUE(model.is_object());
  const auto text_of = [&](const std::string& css) {
    const json t = browser_->run("const e = document.querySelector(arguments[0]); return e ? e.textContent : null;",
                                 json::array({css}));
    return t.is_string() ? t.get<std::string>() : std::string("(none: " + css + ")");
  };
  for (const auto& p : model["params"]) {
    const std::string name = p["name"], unit = p["unit"];
    // An amount the fit found none of is set: scaling none leaves none.
    const bool scaled = p["absorber"].get<bool>() && fit["params"][name].get<double>() > 0;
    const std::string slider = (scaled ? "#scale-" : "#set-") + name;
    EXPECT_NE(text_of("label:has(" + slider + ")").find(p["label"].get<std::string>() + " (" + unit + ")"),
              std::string::npos)
        << name;
    EXPECT_EQ(text_of("#fit-params tr[data-param='" + name + "'] td.unit"), unit) << name;
  }
  EXPECT_EQ(browser_->run("return document.querySelectorAll('#render-controls input[type=range]').length;"),
            model["params"].size());
  EXPECT_EQ(browser_->run("return document.querySelectorAll('#scale-oxyhemoglobin, #scale-deoxyhemoglobin, "
                          "[id^=set-oxyhemoglobin], [id^=set-deoxyhemoglobin]').length;"),
            0);
  EXPECT_FALSE(browser_->run("return !!document.getElementById('scale-oxygen_saturation');").get<bool>());
  for (const auto& d : model["derived"]) {
    if (fit["params"].contains(d["name"])) continue;  // the model fits it: shown as a parameter
    EXPECT_EQ(text_of("#fit-params tr[data-param='" + d["name"].get<std::string>() + "'] td.unit"),
              d["unit"].get<std::string>());
  }
  // The RMSE and ΔE2000 beside their units.
  ASSERT_EQ(model["fit_quality"].size(), 2u);
  for (const auto& q : model["fit_quality"]) {
    const std::string row = "#fit-params tr[data-param='" + q["name"].get<std::string>() + "']";
    EXPECT_EQ(text_of(row + " th"), q["label"].get<std::string>()) << q;
    EXPECT_EQ(text_of(row + " td.unit"), q["unit"].get<std::string>()) << q;
  }
  // The measured spectrum's skin tone, as the fit gives it, beside its units.
  ASSERT_EQ(model["skin_tone"].size(), 4u);
  ASSERT_TRUE(fit.contains("skin_tone")) << fit;
  for (const auto& q : model["skin_tone"]) {
    const std::string name = q["name"], row = "#fit-params tr[data-param='" + name + "']";
    EXPECT_EQ(text_of(row + " th"), q["label"].get<std::string>()) << q;
    EXPECT_EQ(text_of(row + " td.unit"), q["unit"].get<std::string>()) << q;
    const json& value = fit["skin_tone"][name];
    if (value.is_string()) {
      std::string spaced = value.get<std::string>();
      std::ranges::replace(spaced, '_', ' ');
      EXPECT_EQ(text_of(row + " td.value"), spaced);
    } else {
      ASSERT_TRUE(value.is_number()) << name;
      EXPECT_NEAR(std::stod(text_of(row + " td.value")), value.get<double>(), 1e-2 * std::abs(value.get<double>()));
    }
  }
  // The saturation is set, not scaled: moving its slider puts the value into the render's query.
  browser_->run(
      "const s = document.getElementById('set-oxygen_saturation'); s.value = '0.5'; "
      "s.dispatchEvent(new Event('change'));");
  EXPECT_TRUE(
      browser_->wait_until("const q = new URLSearchParams(document.getElementById('render').dataset.query || '');"
                           "return q.get('oxygen_saturation') === '0.5' && q.get('scale_melanin') === '4';",
                           60s))
      << browser_->run("return document.getElementById('render').dataset.query;");
  EXPECT_EQ(text_of("output[for='set-oxygen_saturation']"), "0.500");
  browser_->run("document.getElementById('render').scrollIntoView();");
  shot("05-render.png");
  // Back to the fitted values: the render's query changes nothing.
  browser_->click(browser_->find("#render-reset"));
  EXPECT_TRUE(browser_->wait_until(
      "return document.getElementById('render').dataset.query === 'illuminant=D65&size=384x384';", 60s))
      << browser_->run("return document.getElementById('render').dataset.query;");

  // Export: the CSV the button saves is the API's.
  browser_->open(url("#/sessions/1"));
  browser_->find("#export-csv");
  browser_->run(
      "window.savedFiles = []; window.savedBlobs = [];"
      "const makeUrl = URL.createObjectURL;"
      "URL.createObjectURL = (blob) => { window.savedBlobs.push(blob); return makeUrl(blob); };"
      "HTMLAnchorElement.prototype.click = function () { window.savedFiles.push(this.download); };");
  browser_->click(browser_->find("#export-csv"));
  ASSERT_TRUE(browser_->wait_until("return window.savedFiles.length === 1;"));
  const json saved = browser_->run_async(
      "const done = arguments[arguments.length - 1];"
      "window.savedBlobs.find(b => b.type === 'text/csv').text().then(t => done({name: window.savedFiles[0], text: "
      "t}));");
  EXPECT_EQ(saved["name"], "session-1.csv");
  EXPECT_EQ(saved["text"], http_request(port_, "GET", "/api/v1/sessions/1/export.csv").body);

  // The list, filtered by site, shows the sessions the API lists.
  browser_->open(url("#/sessions?site=forearm"));
  browser_->find("#sessions tr[data-session]");
  EXPECT_EQ(browser_->run("return document.querySelectorAll('#sessions tr[data-session]').length;"),
            get("/api/v1/sessions?site=forearm")["sessions"].size());
  browser_->open(url("#/sessions?site=cheek"));
  EXPECT_TRUE(
      browser_->wait_until("return document.querySelectorAll('#sessions tr[data-session]').length === 0 && "
                           "!!document.getElementById('new-session');"));
}

// The console offers the settings the connected meter takes: the PR-650's averages and sync
// (to its 40-250 Hz), and neither extended sensitivity nor apertures, which it does not have.
TEST_F(WebConsoleTest, APr650IsOfferedOnlyTheSettingsItTakes) {
  ASSERT_TRUE(new_session_screen_with("#averages"));
  EXPECT_EQ(browser_->run("return [...document.querySelectorAll('#sync option')].map((o) => o.value);"),
            json::array({"off", "auto", "frequency"}));
  EXPECT_EQ(browser_->run("const hz = document.getElementById('sync-hz'); return [hz.min, hz.max];"),
            json::array({"40", "250"}));
  EXPECT_EQ(browser_->run("return !!document.getElementById('aperture');"), false);
  EXPECT_EQ(browser_->run("return !!document.getElementById('extended-sensitivity');"), false);
}

class WebConsolePr670Test : public WebConsoleTest {
 protected:
  WebConsolePr670Test() { meter_ = {"--model", "pr670"}; }
};

// A PR-670's settings, apertures by its own names among them, chosen in the console reach the
// job and are stored with the reading; the measurement's screen says how it was measured.
TEST_F(WebConsolePr670Test, TheMetersSettingsChosenInTheConsoleAreStoredWithTheReading) {
  ASSERT_TRUE(new_session_screen_with("#aperture"));
  EXPECT_EQ(browser_->run("return [...document.querySelectorAll('#aperture option')].map((o) => o.value);"),
            json::array({"", "1 deg", "1/2 deg", "1/4 deg", "1/8 deg"}));
  browser_->run(
      "document.getElementById('integration').value = '100';"
      "document.getElementById('averages').value = '2';"
      "const sync = document.getElementById('sync'); sync.value = 'frequency'; sync.dispatchEvent(new Event('change'));"
      "document.getElementById('sync-hz').value = '60';"
      "document.getElementById('extended-sensitivity').checked = true;"
      "document.getElementById('aperture').value = '1/4 deg';");
  browser_->click(browser_->find("#measure-white"));
  ASSERT_EQ(job_end_state(), "succeeded") << browser_->text(browser_->find("#job-status")) << rig_->logs();
  const json job =
      get("/api/v1/jobs/" + browser_->run("return document.getElementById('job').dataset.job;").get<std::string>());
  const long long id = job["result"]["measurement_id"].get<long long>();
  const json settings = get("/api/v1/measurements/" + std::to_string(id))["provenance"]["settings"];
  EXPECT_EQ(settings["integration_ms"], 100) << settings;
  EXPECT_EQ(settings["averages"], 2) << settings;
  EXPECT_EQ(settings["sync"], "60 Hz (user)") << settings;
  EXPECT_EQ(settings["extended_sensitivity"], true) << settings;
  EXPECT_EQ(settings["aperture"], "1/4 deg") << settings;
  shot("07-meter-settings.png");

  browser_->open(url("#/measurements/" + std::to_string(id)));
  const std::string shown = browser_->text(browser_->find("#measurement-settings"));
  for (const char* part :
       {"exposure 100 ms", "2 meter average(s)", "sync 60 Hz (user)", "extended sensitivity", "aperture 1/4 deg"})
    EXPECT_NE(shown.find(part), std::string::npos) << part << " not in: " << shown;
}

TEST_F(WebConsoleTest, ARefusedRequestIsShownAndTheConsoleKeepsWorking) {
  browser_->open(url("#/measurements/999"));
  const std::string error = browser_->find("main .error");
  EXPECT_NE(browser_->text(error).find("measurement 999 does not exist"), std::string::npos) << browser_->text(error);
  // A sample before any white: the job fails and says why.
  ASSERT_EQ(http_request(port_, "POST", "/api/v1/sessions", R"({"site": "palm", "subject": "v"})").status, 201);
  browser_->open(url("#/sessions/1"));
  browser_->click(browser_->find("#measure-sample"));
  EXPECT_EQ(job_end_state(), "failed");
  EXPECT_NE(browser_->text(browser_->find("#job-status")).find("(no_white: measure the white standard of session"),
            std::string::npos)
      << browser_->text(browser_->find("#job-status"));
  shot("06-failed-job.png");
}

}  // namespace
}  // namespace skinspec::testing
