#pragma once
// Test helper: a headless Chromium driven through ChromeDriver's W3C WebDriver protocol, for
// tests of the web console in a real browser. Every call fails the test (gtest ADD_FAILURE)
// with ChromeDriver's message rather than throwing, and returns an empty value.

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "skinspec/testkit/process.hpp"

namespace skinspec::testing {

class Browser {
 public:
  // Whether Debian's chromium and chromium-driver are installed (scripts/setup installs them).
  static bool available();

  // Starts chromedriver and a headless Chromium with a fresh profile under `profile_dir`.
  explicit Browser(const std::string& profile_dir, int width = 1400, int height = 1100);
  ~Browser();
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

  bool ready() const { return !session_.empty(); }
  void open(const std::string& url);
  // The first element matching `css`, waiting up to `timeout` for it; empty when none came.
  std::string find(const std::string& css, std::chrono::milliseconds timeout = std::chrono::seconds(10));
  void click(const std::string& element);
  void type(const std::string& element, const std::string& text);
  std::string text(const std::string& element);
  // Runs `script` (a function body; `arguments` holds `args`) in the page; its return value.
  nlohmann::json run(const std::string& script, const nlohmann::json& args = nlohmann::json::array());
  // Runs an async script whose last argument is the callback to call with the result.
  nlohmann::json run_async(const std::string& script, const nlohmann::json& args = nlohmann::json::array());
  // Waits until `script` returns true; whether it did within `timeout`.
  bool wait_until(const std::string& script, std::chrono::milliseconds timeout = std::chrono::seconds(15));
  // Saves a PNG of the viewport.
  bool screenshot(const std::string& path);

 private:
  nlohmann::json command(const std::string& method, const std::string& path, const nlohmann::json& body = nullptr);

  std::unique_ptr<BackgroundProcess> driver_;
  unsigned short port_ = 0;
  std::string session_;
};

}  // namespace skinspec::testing
