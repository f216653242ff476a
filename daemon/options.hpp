#pragma once
// skinspecd's settings: command-line flags over an optional JSON config file. The token file is
// read by skinspec::tokens (skinspec/api/tokens.hpp), as `skinspec token` writes it.

#include <expected>
#include <functional>
#include <optional>
#include <string>

#include "skinspec/api/router.hpp"
#include "skinspec/api/server.hpp"
#include "skinspec/api/tls.hpp"
#include "measure_policy.hpp"

namespace skinspec::daemon {

struct Options {
  std::string listen = "127.0.0.1:8650";
  std::string db = "skinspec.db";
  std::string device;          // serial:, tcp:, usb: URI or "auto"; empty: no instrument
  std::string model = "auto";  // the meter's model (a profile id), or auto: found out when connecting
  std::string token_file;
  // HTTPS: the server's PEM certificate (chain) and its private key; both or neither.
  std::string tls_cert;
  std::string tls_key;
  // Skin maps: the directory whose cubes POST /api/v1/maps may name (empty: uploads only), and
  // where map jobs work (empty: the system's temporary directory).
  std::string data_dir;
  std::string work_dir;
  std::string bench;  // this PC's bench among those writing one database; empty: the host name
  int lease_s = 15;   // how long the bench may stay silent before other programs count it gone
  std::string log_level = "info";
  std::string config;
  std::size_t body_limit = 1024 * 1024;
  std::size_t upload_limit = 512 * 1024 * 1024;
  std::size_t max_connections = 512;
  std::size_t max_connections_per_client = 64;
  int read_timeout_ms = 10000;
  int threads = 2;     // workers running the router for the light routes
  int io_threads = 1;  // each with the connections it was given
  // Fits and renders: their threads, and the requests that may wait for one.
  std::size_t compute_threads = 2;
  std::size_t compute_queue = 8;
  // The instrument connection: backoff between attempts while it is unreachable, and how
  // often an idle meter is checked (0: never).
  int reconnect_initial_ms = 500;
  int reconnect_max_ms = 30000;
  int instrument_check_ms = 2000;
  MeasurePolicy measure;  // max_rejected_readings, white_max_age_s, lamp_change_tolerance
};

// Fills the fields of `options` not given on the command line (`given(flag name)` false) from
// the JSON object `text` (keys: the flag names with '_' for '-'); an explanation for bad JSON,
// a wrong type or an unknown key.
std::expected<void, std::string> apply_config_json(const std::string& text, Options& options,
                                                   const std::function<bool(const std::string&)>& given);

// The TLS files when both --tls-cert and --tls-key are given, nothing when neither is; an
// explanation naming the missing one otherwise.
std::expected<std::optional<api::TlsFiles>, std::string> tls_files(const Options& options);

// "host:port" → address and port.
std::expected<std::pair<std::string, unsigned short>, std::string> parse_listen(const std::string& text);
bool is_loopback(const std::string& address);

}  // namespace skinspec::daemon
