// skinspecd: stored skin spectra, sessions and fits over HTTP/JSON (docs/api.md).

#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <boost/asio/signal_set.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "bench_keeper.hpp"
#include "options.hpp"
#include "supervisor.hpp"
#include "fitter_loader.hpp"
#include "skinspec/drivers/emergency_quit.hpp"
#include "skinspec/api/tokens.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/version.hpp"

namespace {

void reload_tokens(const std::string& file_name, skinspec::api::Keyring& tokens, int reload) {
  if (auto file = skinspec::api::read_token_file(file_name); !file) {
    spdlog::error("event=token_reload_failed reload={} tokens_kept={} message=\"{}\"", reload, tokens.size(),
                  file.error());
  } else {
    tokens.replace(std::move(file->tokens));
    spdlog::info("event=tokens_reloaded reload={} tokens={} file=\"{}\"", reload, tokens.size(), file_name);
  }
}

// A renewed certificate: new connections present it, open ones keep the one they started with.
void reload_tls(const skinspec::api::TlsFiles& files, skinspec::api::TlsCredentials& tls, int reload) {
  if (auto context = skinspec::api::make_tls_context(files); !context) {
    spdlog::error("event=tls_reload_failed reload={} message=\"{}; the certificate loaded before is kept\"", reload,
                  context.error());
  } else {
    tls.replace(std::move(*context));
    spdlog::info("event=tls_reloaded reload={} certificate=\"{}\"", reload, files.certificate);
  }
}

int serve(const skinspec::daemon::Options& o) {
  using namespace skinspec;
  const auto listen = daemon::parse_listen(o.listen);
  if (!listen) return spdlog::error("event=bad_option message=\"{}\"", listen.error()), 2;
  const auto tls_files = daemon::tls_files(o);
  if (!tls_files) return spdlog::error("event=bad_option message=\"{}\"", tls_files.error()), 2;
  std::shared_ptr<api::TlsCredentials> tls;  // its context replaced on SIGHUP
  if (*tls_files) {
    auto context = api::make_tls_context(**tls_files);
    if (!context) return spdlog::error("event=bad_tls message=\"{}\"", context.error()), 2;
    tls = std::make_shared<api::TlsCredentials>(std::move(*context));
  }
  const auto model = drivers::ModelChoice::parse(o.model);
  if (!model) return spdlog::error("event=bad_option message=\"--model: {}\"", model.error()), 2;
  api::RouterContext context;
  std::shared_ptr<api::Keyring> tokens;  // replaced on SIGHUP; the router only reads it
  if (!o.token_file.empty()) {
    auto file = api::read_token_file(o.token_file);
    if (!file) return spdlog::error("event=bad_token_file message=\"{}\"", file.error()), 2;
    if (file->format == api::TokenFileFormat::legacy)
      spdlog::info("event=legacy_token_file file=\"{}\" message=\"read_token has scope read, operator_token admin\"",
                   o.token_file);
    tokens = std::make_shared<api::Keyring>(std::move(file->tokens));
    context.tokens = tokens;
  } else if (!daemon::is_loopback(listen->first)) {
    spdlog::error("event=refused message=\"listening on {} needs --token-file (made by skinspec token new)\"",
                  listen->first);
    return 2;
  }
  // Off loopback a bearer token crosses the network: without TLS anyone on the path can read it.
  if (!tls && !daemon::is_loopback(listen->first))
    spdlog::warn("event=plain_http address={} message=\"tokens travel unencrypted: give --tls-cert and --tls-key\"",
                 listen->first);

  const std::string bench = o.bench.empty() ? daemon::host_name() : o.bench;
  if (!daemon::valid_bench_name(bench))
    return spdlog::error("event=bad_option message=\"--bench: '{}' is not 1-64 letters, digits, '-', '_' or '.'\"",
                         bench),
           2;
  if (o.lease_s < 2 || o.lease_s > 3600)
    return spdlog::error("event=bad_option message=\"--lease must be 2 to 3600 seconds\""), 2;
  auto fitter = skinspec::load_fitter();
  if (!fitter) return spdlog::error("event=model_load_failed message=\"{}\"", fitter.error()), 1;
  // A daemon without a meter is no bench: the sessions it opens belong to the first bench that
  // measures in them.
  store::OpenOptions open_options;
  open_options.bench = o.device.empty() ? std::string() : bench;
  auto db = store::Store::open(o.db, open_options);
  if (!db)
    return spdlog::error("event=db_open_failed db=\"{}\" kind={} message=\"{}\"", store::display_target(o.db),
                         store::to_string(db.error().kind), db.error().message),
           store::is_bad_target(db.error().kind) ? 2 : 1;
  if (!db->recovery().interrupted_sessions.empty())
    spdlog::warn("event=recovered interrupted_sessions={}", db->recovery().interrupted_sessions.size());
  context.store = &*db;
  context.fitter = &*fitter;
  for (const auto& [flag, dir] : {std::pair{"--data-dir", o.data_dir}, std::pair{"--work-dir", o.work_dir}}) {
    std::error_code error;
    if (!dir.empty() && !std::filesystem::is_directory(dir, error))
      return spdlog::error("event=bad_option message=\"{} {}: not a directory\"", flag, dir), 2;
  }
  context.maps = {o.data_dir, o.work_dir};
  if (o.reconnect_initial_ms < 1 || o.reconnect_max_ms < 1 || o.instrument_check_ms < 0)
    return spdlog::error(
               "event=bad_option message=\"reconnect_initial_ms and reconnect_max_ms must be positive, "
               "instrument_check_ms not negative\""),
           2;
  // The jobs of every kind, measurements and the router's imports and refits alike.
  const auto board = std::make_shared<api::JobBoard>();
  context.job_board = board;
  std::unique_ptr<daemon::Supervisor> supervisor;
  std::unique_ptr<daemon::BenchKeeper> keeper;  // stopped before the supervisor
  if (!o.device.empty()) {
    supervisor = std::make_unique<daemon::Supervisor>(o.device, *db, *fitter, *model, board);
    supervisor->set_policy(o.measure);
    context.acquisition = supervisor.get();
    daemon::Supervisor::ConnectionSettings link;
    link.backoff = {std::chrono::milliseconds(o.reconnect_initial_ms), std::chrono::milliseconds(o.reconnect_max_ms)};
    link.check_interval = std::chrono::milliseconds(o.instrument_check_ms);
    supervisor->start_connection(std::move(link));
    supervisor->set_bench(bench, db->backend() == store::Backend::postgresql);
    supervisor->start();
    keeper = std::make_unique<daemon::BenchKeeper>(
        *db, *supervisor,
        daemon::BenchSettings{std::chrono::seconds(o.lease_s), db->backend() == store::Backend::postgresql});
    if (auto started = keeper->start(); !started)
      return spdlog::error("event=bench_failed bench={} message=\"{}\"", bench, started.error().message), 1;
    spdlog::info("event=instrument device=\"{}\" model={} message=\"connecting in the background\"", o.device,
                 model->to_string());
  }

  const api::Router router(context);
  api::ServerOptions options;
  options.address = listen->first;
  options.port = listen->second;
  options.body_limit = o.body_limit;
  options.upload_limit = o.upload_limit;
  options.max_connections = o.max_connections;
  options.max_connections_per_client = o.max_connections_per_client;
  options.compute_threads = o.compute_threads;
  options.compute_queue = o.compute_queue;
  options.read_timeout = std::chrono::milliseconds(o.read_timeout_ms);
  options.io_threads = o.io_threads;
  options.worker_threads = o.threads;
  options.tls = tls;
  api::Server server(router, options);
  if (auto ok = server.listen(); !ok) return spdlog::error("event=listen_failed message=\"{}\"", ok.error()), 1;
  if (const auto limits = server.limits(); limits.max_connections < o.max_connections)
    spdlog::warn(
        "event=connection_cap requested={} effective={} open_files_limit={} message=\"the file-descriptor limit "
        "(ulimit -n) "
        "leaves room for fewer connections than --max-connections\"",
        o.max_connections, limits.max_connections, limits.descriptor_limit);

  // SIGHUP reads the token file again, so that a token is added or revoked without a restart,
  // and the TLS certificate and key, so that a renewed certificate is served. A file that cannot
  // be read or parsed then leaves what it holds as it was: a mistake in it must neither stop the
  // service nor open it to everyone.
  boost::asio::signal_set hangups(server.context(), SIGHUP);
  boost::asio::signal_set signals(server.context(), SIGINT, SIGTERM);
  signals.async_wait([&server, &hangups](const boost::system::error_code& ec, int signal) {
    if (ec) return;
    spdlog::info("event=stopping signal={}", signal);
    hangups.cancel();  // the wait for the next SIGHUP would keep the server's context running
    server.stop();
  });
  int reloads = 0;
  std::function<void()> await_hangup = [&] {
    hangups.async_wait([&](const boost::system::error_code& ec, int) {
      if (ec) return;
      ++reloads;
      if (tokens) reload_tokens(o.token_file, *tokens, reloads);
      if (tls) reload_tls(**tls_files, *tls, reloads);
      if (!tokens && !tls)
        spdlog::warn("event=nothing_reloaded reload={} message=\"started without --token-file or --tls-cert\"",
                     reloads);
      await_hangup();
    });
  };
  await_hangup();
  const char* scheme = tls ? "https" : "http";
  spdlog::info("event=listening scheme={} address={} port={} db=\"{}\" auth={} tokens={} version={}", scheme,
               options.address, server.port(), store::display_target(o.db), tokens ? "tokens" : "none",
               tokens ? tokens->size() : 0, skinspec::kVersion);
  // For people and for programs waiting for the service to come up.
  std::cout << "skinspecd listening on " << scheme << "://"
            << (options.address.find(':') != std::string::npos ? "[" + options.address + "]" : options.address) << ':'
            << server.port() << std::endl;
  server.run();
  if (keeper) keeper->stop();
  if (supervisor) supervisor->stop();
  spdlog::info("event=stopped db=\"{}\"", store::display_target(o.db));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // A meter in remote mode is sent Q even if this process dies of a fatal signal.
  skinspec::drivers::install_emergency_quit();
  skinspec::daemon::Options o;
  CLI::App app{"skinspecd: stored skin spectra, sessions and fits over HTTP/JSON"};
  app.set_version_flag("--version", "skinspecd " + std::string(skinspec::kVersion));
  app.add_option("--listen", o.listen, "HOST:PORT to listen on (port 0: any free port)")->capture_default_str();
  app.add_option("--db", o.db,
                 "the store: a SQLite file (PATH or sqlite:PATH, created when missing) or a PostgreSQL database "
                 "(postgresql://USER@HOST:PORT/DBNAME; the password from PGPASSFILE or ~/.pgpass)")
      ->capture_default_str();
  app.add_option(
      "--device", o.device,
      "instrument connection URI (serial:, tcp: or usb:VID:PID[:SERIAL]) or 'auto' (a Photo Research meter on USB, "
      "else the first USB serial adapter)");
  app.add_option("--model", o.model,
                 "the meter's model: auto (asked when connecting) or a model id such as pr650, pr670 or pr730")
      ->capture_default_str();
  app.add_option("--reconnect-initial-ms", o.reconnect_initial_ms,
                 "wait after the first failed connection attempt; doubles on each failure")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();
  app.add_option("--reconnect-max-ms", o.reconnect_max_ms, "longest wait between connection attempts")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();
  app.add_option("--instrument-check-ms", o.instrument_check_ms, "how often an idle meter is checked (0: never)")
      ->check(CLI::Range(0, 3600000))
      ->capture_default_str();
  app.add_option("--bench", o.bench,
                 "this PC's bench among the skinspecd writing one database (default: the host name)");
  app.add_option("--lease", o.lease_s,
                 "seconds this bench may stay silent before the others count it gone and interrupt its jobs")
      ->check(CLI::Range(2, 3600))
      ->capture_default_str();
  app.add_option("--data-dir", o.data_dir,
                 "the directory whose spectral images POST /api/v1/maps may name by path (default: uploads only)");
  app.add_option("--work-dir", o.work_dir,
                 "where map jobs keep uploads and answers until they are stored (default: the temporary directory)");
  app.add_option("--token-file", o.token_file,
                 "0600 JSON file of named tokens' hashes (skinspec token new), or with read_token and operator_token; "
                 "read again on SIGHUP; required off loopback");
  app.add_option("--tls-cert", o.tls_cert,
                 "PEM certificate (then any intermediates) to serve HTTPS with; needs --tls-key; read again on "
                 "SIGHUP. What makes tokens safe to send off loopback");
  app.add_option("--tls-key", o.tls_key, "PEM private key of --tls-cert, unencrypted");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error, critical or off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
      ->capture_default_str();
  app.add_option("--config", o.config, "JSON file of settings (keys as the flags, '_' for '-'); flags win");
  app.add_option("--body-limit", o.body_limit, "largest request body in bytes")->capture_default_str();
  app.add_option("--upload-limit", o.upload_limit, "largest file to import, in bytes")->capture_default_str();
  app.add_option("--max-connections", o.max_connections,
                 "connections held at once (fewer if the file-descriptor limit is lower); a newcomer over it takes the "
                 "place of the "
                 "longest-idle one")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1000000}))
      ->capture_default_str();
  app.add_option("--max-connections-per-client", o.max_connections_per_client,
                 "connections one client address may hold at once")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1000000}))
      ->capture_default_str();
  app.add_option("--compute-threads", o.compute_threads,
                 "threads running fits and renders, apart from the other requests")
      ->check(CLI::Range(std::size_t{1}, std::size_t{64}))
      ->capture_default_str();
  app.add_option("--compute-queue", o.compute_queue,
                 "fits and renders that may wait for a thread; beyond them a 503 with Retry-After")
      ->check(CLI::Range(std::size_t{0}, std::size_t{10000}))
      ->capture_default_str();
  app.add_option("--read-timeout-ms", o.read_timeout_ms, "time a client has to send a whole request")
      ->capture_default_str();
  app.add_option("--threads", o.threads, "workers answering every request but fits and renders")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--io-threads", o.io_threads,
                 "threads reading requests and writing answers, each for the connections it is given")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--max-rejected-readings", o.measure.max_rejected_readings,
                 "readings with a bad quality code a job stores and retries before it fails")
      ->capture_default_str();
  app.add_option("--white-max-age-s", o.measure.white_max_age_s, "warn on samples measured against an older white")
      ->capture_default_str();
  app.add_option("--lamp-change-tolerance", o.measure.lamp_change_tolerance,
                 "warn when a white's band-integrated radiance differs from the previous white's by more (0.05 = 5 %)")
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end here too, with status 0; a bad flag is bad input: 2.
    return app.exit(e) == 0 ? 0 : 2;
  }

  auto logger = spdlog::stderr_color_mt("skinspecd");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%fZ level=%l %v", spdlog::pattern_time_type::utc);

  if (!o.config.empty()) {
    std::ifstream in(o.config);
    if (!in) return spdlog::error("event=bad_config path=\"{}\" message=\"cannot read\"", o.config), 2;
    std::stringstream text;
    text << in.rdbuf();
    auto applied = skinspec::daemon::apply_config_json(text.str(), o, [&app](const std::string& flag) {
      // A key that names no flag is not given on the command line; the config refuses it.
      try {
        return app.count("--" + flag) > 0;
      } catch (const CLI::OptionNotFound&) {
        return false;
      }
    });
    if (!applied) return spdlog::error("event=bad_config path=\"{}\" message=\"{}\"", o.config, applied.error()), 2;
  }
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  if (auto bad = skinspec::daemon::check(o.measure)) return spdlog::error("event=bad_option message=\"{}\"", *bad), 2;
  try {
    return serve(o);
  } catch (const std::exception& e) {
    spdlog::critical("event=fatal message=\"{}\"", e.what());
    return 1;
  }
}
