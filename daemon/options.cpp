#include "options.hpp"

#include <charconv>

#include <boost/asio/ip/address.hpp>
#include <nlohmann/json.hpp>

namespace skinspec::daemon {

using nlohmann::json;

std::expected<void, std::string> apply_config_json(const std::string& text, Options& o,
                                                   const std::function<bool(const std::string&)>& given) {
  const json config = json::parse(text, nullptr, false);
  if (config.is_discarded() || !config.is_object()) return std::unexpected("the config file is not a JSON object");
  try {
    for (const auto& item : config.items()) {
      const std::string& key = item.key();
      const json& v = item.value();
      std::string flag = key;
      for (char& ch : flag) ch = ch == '_' ? '-' : ch;
      if (given(flag)) continue;
      if (key == "listen") o.listen = v.get<std::string>();
      else if (key == "db") o.db = v.get<std::string>();
      else if (key == "device") o.device = v.get<std::string>();
      else if (key == "model") o.model = v.get<std::string>();
      else if (key == "token_file") o.token_file = v.get<std::string>();
      else if (key == "tls_cert") o.tls_cert = v.get<std::string>();
      else if (key == "tls_key") o.tls_key = v.get<std::string>();
      else if (key == "bench") o.bench = v.get<std::string>();
      else if (key == "data_dir") o.data_dir = v.get<std::string>();
      else if (key == "work_dir") o.work_dir = v.get<std::string>();
      else if (key == "lease") o.lease_s = v.get<int>();
      else if (key == "log_level") o.log_level = v.get<std::string>();
      else if (key == "body_limit") o.body_limit = v.get<std::size_t>();
      else if (key == "upload_limit") o.upload_limit = v.get<std::size_t>();
      else if (key == "max_connections") o.max_connections = v.get<std::size_t>();
      else if (key == "max_connections_per_client") o.max_connections_per_client = v.get<std::size_t>();
      else if (key == "compute_threads") o.compute_threads = v.get<std::size_t>();
      else if (key == "compute_queue") o.compute_queue = v.get<std::size_t>();
      else if (key == "read_timeout_ms") o.read_timeout_ms = v.get<int>();
      else if (key == "threads") o.threads = v.get<int>();
      else if (key == "io_threads") o.io_threads = v.get<int>();
      else if (key == "reconnect_initial_ms") o.reconnect_initial_ms = v.get<int>();
      else if (key == "reconnect_max_ms") o.reconnect_max_ms = v.get<int>();
      else if (key == "instrument_check_ms") o.instrument_check_ms = v.get<int>();
      else if (key == "max_rejected_readings") o.measure.max_rejected_readings = v.get<int>();
      else if (key == "white_max_age_s") o.measure.white_max_age_s = v.get<double>();
      else if (key == "lamp_change_tolerance") o.measure.lamp_change_tolerance = v.get<double>();
      else return std::unexpected("unknown config key '" + key + "'");
    }
  } catch (const json::exception& e) {
    return std::unexpected(std::string("config: ") + e.what());
  }
  // As the command line's checks have them.
  for (const auto& [key, value] : {std::pair{"threads", o.threads}, std::pair{"io_threads", o.io_threads}})
    if (value < 1 || value > 64)
      return std::unexpected(std::string("config: ") + key + " " + std::to_string(value) + " is not 1-64");
  return {};
}

std::expected<std::optional<api::TlsFiles>, std::string> tls_files(const Options& o) {
  if (o.tls_cert.empty() && o.tls_key.empty()) return std::nullopt;
  if (o.tls_key.empty()) return std::unexpected("--tls-cert needs --tls-key, the certificate's private key");
  if (o.tls_cert.empty()) return std::unexpected("--tls-key needs --tls-cert, the key's certificate");
  return api::TlsFiles{o.tls_cert, o.tls_key};
}

std::expected<std::pair<std::string, unsigned short>, std::string> parse_listen(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) return std::unexpected("--listen wants HOST:PORT, not '" + text + "'");
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  unsigned port = 0;
  const char* first = text.data() + colon + 1;
  const char* last = text.data() + text.size();
  const auto [end, ec] = std::from_chars(first, last, port);
  if (ec != std::errc{} || end != last || port > 65535 || first == last)
    return std::unexpected("bad port in '" + text + "'");
  boost::system::error_code bad;
  boost::asio::ip::make_address(host, bad);
  if (bad) return std::unexpected("bad address '" + host + "' (give an IP address)");
  return std::pair{host, static_cast<unsigned short>(port)};
}

bool is_loopback(const std::string& address) {
  boost::system::error_code ec;
  const auto a = boost::asio::ip::make_address(address, ec);
  return !ec && a.is_loopback();
}

}  // namespace skinspec::daemon
