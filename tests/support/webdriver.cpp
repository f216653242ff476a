#include "support/webdriver.hpp"

#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "skinspec/client/http_client.hpp"

namespace skinspec::testing {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

namespace {

constexpr const char* kChromium = "/usr/bin/chromium";
constexpr const char* kChromeDriver = "/usr/bin/chromedriver";
constexpr const char* kElementKey = "element-6066-11e4-a52e-4f735466cecf";  // fixed by the W3C spec

std::string base64_decode(const std::string& text) {
  auto value = [](char ch) -> int {
    if (ch >= 'A' && ch <= 'Z') return ch - 'A';
    if (ch >= 'a' && ch <= 'z') return ch - 'a' + 26;
    if (ch >= '0' && ch <= '9') return ch - '0' + 52;
    if (ch == '+') return 62;
    if (ch == '/') return 63;
    return -1;
  };
  std::string out;
  unsigned bits = 0;
  int count = 0;
  for (char ch : text) {
    const int v = value(ch);
    if (v < 0) continue;  // padding and line breaks
    bits = (bits << 6) | static_cast<unsigned>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out.push_back(static_cast<char>((bits >> count) & 0xffu));
    }
  }
  return out;
}

}  // namespace

bool Browser::available() { return std::filesystem::exists(kChromium) && std::filesystem::exists(kChromeDriver); }

Browser::Browser(const std::string& profile_dir, int width, int height) {
  driver_ = std::make_unique<BackgroundProcess>(kChromeDriver, std::vector<std::string>{"--port=0"});
  const auto line = driver_->wait_for_stdout_line("ChromeDriver was started successfully on port ", 30s);
  if (!line) {
    ADD_FAILURE() << "chromedriver did not start: " << driver_->err();
    return;
  }
  port_ = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(' ') + 1)));
  // Headless, no sandbox (tests may run as root), and no background connections: the machine
  // has no network beyond loopback.
  const json args = {"--headless",
                     "--no-sandbox",
                     "--disable-gpu",
                     "--disable-quic",
                     "--no-first-run",
                     "--disable-background-networking",
                     "--disable-component-update",
                     "--disable-sync",
                     "--disable-dev-shm-usage",
                     "--user-data-dir=" + profile_dir,
                     "--window-size=" + std::to_string(width) + "," + std::to_string(height)};
  const json caps = {
      {"capabilities",
       {{"alwaysMatch",
         {{"browserName", "chrome"}, {"goog:chromeOptions", {{"binary", kChromium}, {"args", args}}}}}}}};
  const json reply = command("POST", "/session", caps);
  if (reply.is_object() && reply.contains("sessionId")) session_ = reply["sessionId"].get<std::string>();
}

Browser::~Browser() {
  if (!session_.empty()) (void)command("DELETE", "/session/" + session_);
  if (driver_) {
    driver_->send_signal(SIGTERM);
    (void)driver_->wait(10s);
  }
}

json Browser::command(const std::string& method, const std::string& path, const json& body) {
  if (port_ == 0) return nullptr;
  const auto r = http_request(port_, method, path, body.is_null() ? std::string() : body.dump());
  const json reply = r.json();
  if (r.status != 200 || !reply.is_object()) {
    ADD_FAILURE() << "WebDriver " << method << " " << path << " -> " << r.status << " " << r.error << " "
                  << r.body.substr(0, 600);
    return nullptr;
  }
  return reply.value("value", json(nullptr));
}

void Browser::open(const std::string& url) { (void)command("POST", "/session/" + session_ + "/url", {{"url", url}}); }

std::string Browser::find(const std::string& css, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  do {
    const json found = run("const e = document.querySelector(arguments[0]); return e;", json::array({css}));
    if (found.is_object() && found.contains(kElementKey)) return found[kElementKey].get<std::string>();
    std::this_thread::sleep_for(50ms);
  } while (std::chrono::steady_clock::now() < deadline);
  ADD_FAILURE() << "no element '" << css << "' within " << timeout.count() << " ms";
  return {};
}

void Browser::click(const std::string& element) {
  (void)command("POST", "/session/" + session_ + "/element/" + element + "/click", json::object());
}

void Browser::type(const std::string& element, const std::string& text) {
  (void)command("POST", "/session/" + session_ + "/element/" + element + "/value", {{"text", text}});
}

std::string Browser::text(const std::string& element) {
  const json v = command("GET", "/session/" + session_ + "/element/" + element + "/text");
  return v.is_string() ? v.get<std::string>() : std::string();
}

json Browser::run(const std::string& script, const json& args) {
  return command("POST", "/session/" + session_ + "/execute/sync", {{"script", script}, {"args", args}});
}

json Browser::run_async(const std::string& script, const json& args) {
  return command("POST", "/session/" + session_ + "/execute/async", {{"script", script}, {"args", args}});
}

bool Browser::wait_until(const std::string& script, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  do {
    if (run(script) == json(true)) return true;
    std::this_thread::sleep_for(50ms);
  } while (std::chrono::steady_clock::now() < deadline);
  return false;
}

bool Browser::screenshot(const std::string& path) {
  const json v = command("GET", "/session/" + session_ + "/screenshot");
  if (!v.is_string()) return false;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << base64_decode(v.get<std::string>());
  return std::filesystem::file_size(path) > 0;
}

}  // namespace skinspec::testing
