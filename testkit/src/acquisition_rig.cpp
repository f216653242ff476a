#include "skinspec/testkit/acquisition_rig.hpp"

#include <algorithm>
#include <csignal>
#include <fstream>
#include <sstream>
#include <thread>

#include "skinspec/client/http_client.hpp"

namespace skinspec::testing {

using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

namespace {

unsigned short port_of(const std::optional<std::string>& line) {
  return line ? static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1))) : 0;
}

// `flag value` unless `given` sets that flag itself.
void add_default(std::vector<std::string>& args, const std::vector<std::string>& given, const std::string& flag,
                 const std::string& value) {
  if (std::ranges::find(given, flag) == given.end()) args.insert(args.end(), {flag, value});
}

void stop(std::unique_ptr<BackgroundProcess>& process) {
  if (!process) return;
  process->send_signal(SIGTERM);
  (void)process->wait(20s);
  process.reset();
}

}  // namespace

AcquisitionRig::AcquisitionRig(RigOptions options) : options_(std::move(options)) {
  start_sim("127.0.0.1:0");
  if (sim_port != 0) start_daemon({});
}

AcquisitionRig::~AcquisitionRig() {
  stop(daemon);
  stop(sim);
}

std::string AcquisitionRig::logs() const {
  return "skinspecd:\n" + (daemon ? daemon->err() : std::string()) + "\nskinspec-sim:\n" +
         (sim ? sim->err() : std::string());
}

void AcquisitionRig::start_sim(const std::string& listen) {
  std::vector<std::string> args = {"--listen", listen, "--boot-window", "inf"};
  add_default(args, options_.sim_args, "--time-scale", "0");
  if (options_.default_scenes) {
    const std::string white = options_.work_dir + "/white.csv";
    std::ofstream(white) << "wavelength_nm,white\n380,0.99\n780,0.99\n";
    args.insert(args.end(), {"--white", white, "--reflectance", options_.data_dir + "/examples/forearm.csv"});
  }
  args.insert(args.end(), options_.sim_args.begin(), options_.sim_args.end());
  sim = std::make_unique<BackgroundProcess>(options_.bin_dir + "/skinspec-sim", args);
  sim_port = port_of(sim->wait_for_stdout_line("listening on ", 20s));
}

void AcquisitionRig::start_daemon(const std::vector<std::string>& extra_args) {
  std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--db",
                                   db_path(),  "--device",    "tcp:127.0.0.1:" + std::to_string(sim_port)};
  add_default(args, options_.daemon_args, "--log-level", "debug");
  args.insert(args.end(), options_.daemon_args.begin(), options_.daemon_args.end());
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  ProcessOptions process;
  process.environment = options_.daemon_environment;
  daemon = std::make_unique<BackgroundProcess>(options_.bin_dir + "/skinspecd", args, process);
  // http:// or https://, as the daemon_args have it.
  port = port_of(daemon->wait_for_stdout_line("skinspecd listening on http", 30s));
}

ProcessResult AcquisitionRig::stop_daemon(int signal) {
  daemon->send_signal(signal);
  return daemon->wait(20s);
}

void AcquisitionRig::restart_daemon(std::vector<std::string> extra_args) {
  stop(daemon);
  start_daemon(extra_args);
}

void AcquisitionRig::restart_sim() {
  stop(sim);
  start_sim("127.0.0.1:" + std::to_string(sim_port));
}

std::vector<double> first_subject_on_grid(const std::string& csv_path, int first_nm, int last_nm, int step_nm) {
  std::ifstream in(csv_path);
  std::vector<double> wl, r;
  bool header = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    std::stringstream cells(line);
    std::string a, b;
    std::getline(cells, a, ',');
    std::getline(cells, b, ',');
    wl.push_back(std::stod(a));
    r.push_back(std::stod(b));
  }
  std::vector<double> out;
  if (wl.empty()) return out;
  for (int w = first_nm; w <= last_nm; w += step_nm) {
    if (w <= wl.front()) {
      out.push_back(r.front());
      continue;
    }
    if (w >= wl.back()) {
      out.push_back(r.back());
      continue;
    }
    std::size_t i = 1;
    while (wl[i] < w) ++i;
    const double t = (w - wl[i - 1]) / (wl[i] - wl[i - 1]);
    out.push_back(r[i - 1] + t * (r[i] - r[i - 1]));
  }
  return out;
}

long long new_session(unsigned short port, const std::string& subject) {
  const auto r = http_request(port, "POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", subject}}.dump());
  return r.status == 201 ? r.json()["id"].get<long long>() : 0;
}

json submit(unsigned short port, long long session, const json& body, const Headers& headers) {
  const auto r =
      http_request(port, "POST", "/api/v1/sessions/" + std::to_string(session) + "/measurements", body.dump(), headers);
  if (r.status != 202 && r.status != 200) return json{{"status", r.status}, {"body", r.body}};
  return r.json();
}

json get_json(unsigned short port, const std::string& target) { return http_request(port, "GET", target).json(); }

json wait_for_job(unsigned short port, const json& accepted, std::chrono::milliseconds limit) {
  if (!accepted.contains("job_id")) return accepted;
  const std::string path = "/api/v1/jobs/" + std::to_string(accepted["job_id"].get<long long>());
  const auto until = std::chrono::steady_clock::now() + limit;
  json job;
  do {
    job = get_json(port, path);
    const auto state = job.value("state", "");
    if (state != "queued" && state != "running") return job;
    std::this_thread::sleep_for(20ms);
  } while (std::chrono::steady_clock::now() < until);
  return job;
}

}  // namespace skinspec::testing
