#include "job_follow.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <iostream>

#include "common.hpp"

namespace skinspec::cli {

namespace {

using nlohmann::json;

// What a job has done: readings for a measurement, spectra for an import or a refit, with the
// time left when the service knows it.
std::string progress_text(const json& p) {
  if (!p.contains("spectra_total"))
    return fmt::format("{} {}/{}", p.value("phase", "?"), p.value("readings_done", 0), p.value("readings_total", 0));
  std::string text = fmt::format("{} {}/{} spectra", p.value("phase", "?"), p.value("spectra_done", 0LL),
                                 p.value("spectra_total", 0LL));
  if (p.contains("remaining_s") && p["remaining_s"].is_number())
    text += fmt::format(", {:.0f} s left", p["remaining_s"].get<double>());
  return text;
}

class ProgressView {
 public:
  explicit ProgressView(bool terminal) : terminal_(terminal) {}

  void show(const json& job) {
    const json& p = job["progress"];
    std::string status = job.value("state", "?");
    if (job["position"].is_number_integer() && job["position"].get<int>() > 0)
      status += fmt::format(", position {}", job["position"].get<int>());
    status += ", " + progress_text(p);
    if (!terminal_) {
      std::cerr << fmt::format("job {}: {}\n", job.value("id", 0LL), status);
      return;
    }
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(p.value("fraction", 0.0) * kWidth + 0.5);
    std::cerr << fmt::format("\r[{}{}] {:3.0f}%  {:<48}", std::string(static_cast<std::size_t>(filled), '#'),
                             std::string(static_cast<std::size_t>(kWidth - filled), '-'),
                             p.value("fraction", 0.0) * 100, status)
              << std::flush;
    drawn_ = true;
  }
  ~ProgressView() {
    if (drawn_) std::cerr << '\n';
  }

 private:
  bool terminal_;
  bool drawn_ = false;
};

}  // namespace

bool job_finished(const json& job) {
  const auto state = job.value("state", "");
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

json follow_job(const ApiClient& client, long long job_id) {
  json last;
  {
    ProgressView view(::isatty(STDERR_FILENO) == 1);
    client.follow_events("/api/v1/jobs/" + std::to_string(job_id) + "/events",
                         [&](const std::string& name, const std::string& data) {
                           if (name != "job") return;
                           json job = json::parse(data, nullptr, false);
                           if (!job.is_object()) return;
                           view.show(job);
                           last = std::move(job);
                         });
  }
  if (!job_finished(last)) last = client.call("GET", "/api/v1/jobs/" + std::to_string(job_id));
  if (!job_finished(last))
    throw Failure{kUnreachable,
                  fmt::format("the events of job {} ended before the job did (is skinspecd stopping?)", job_id)};
  return last;
}

std::string job_error_text(const json& error) {
  if (!error.is_object()) return "no reason given";
  return fmt::format("{} ({})", error.value("message", ""), error.value("code", "unknown"));
}

}  // namespace skinspec::cli
