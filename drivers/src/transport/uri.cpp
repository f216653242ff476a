// Connection URIs: where an instrument is and how to talk to it, in one string a person can
// type on a command line and a daemon can keep in its configuration.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>
#include <set>
#include <vector>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

std::string_view to_string(TransportError::Kind kind) {
  switch (kind) {
    case TransportError::Kind::timeout:
      return "timeout";
    case TransportError::Kind::interrupted:
      return "interrupted";
    case TransportError::Kind::closed:
      return "closed";
    case TransportError::Kind::io:
      return "io";
    case TransportError::Kind::not_found:
      return "not_found";
  }
  return "unknown";
}

namespace {

constexpr unsigned kDefaultBaud = 9600;
constexpr unsigned kMaxBaud = 4'000'000;
constexpr unsigned kMaxPacingMs = 1000;  // the meters want 50 ms; a second per byte is already absurd

using Parsed = std::expected<ConnectionUri, std::string>;

std::unexpected<std::string> bad(std::string_view text, std::string_view detail) {
  return std::unexpected(fmt::format("bad connection URI '{}': {}", text, detail));
}

std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

std::vector<std::string_view> split(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  for (std::size_t start = 0;;) {
    const auto end = text.find(separator, start);
    parts.push_back(text.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    if (end == std::string_view::npos) return parts;
    start = end + 1;
  }
}

// A whole decimal number within [low, high], with nothing else around it.
std::optional<unsigned long> parse_decimal(std::string_view digits, unsigned long low, unsigned long high) {
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  unsigned long value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (error != std::errc{} || end != digits.data() + digits.size() || value < low || value > high) return std::nullopt;
  return value;
}

// A USB vendor or product id as lsusb prints it: one to four hex digits.
std::optional<unsigned short> parse_usb_id(std::string_view digits) {
  if (digits.empty() || digits.size() > 4 ||
      !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isxdigit(c); }))
    return std::nullopt;
  unsigned value = 0;
  std::from_chars(digits.data(), digits.data() + digits.size(), value, 16);
  return static_cast<unsigned short>(value);
}

std::expected<void, std::string> apply_option(ConnectionUri& uri, std::string_view key, std::string_view value) {
  if (key == "baud") {
    const auto baud = parse_decimal(value, 1, kMaxBaud);
    if (!baud) return std::unexpected(fmt::format("baud '{}' is not a whole number from 1 to {}", value, kMaxBaud));
    uri.baud = static_cast<unsigned>(*baud);
  } else if (key == "flow") {
    const std::string flow = lower(value);
    if (flow == "none") uri.flow = ConnectionUri::Flow::none;
    else if (flow == "rtscts") uri.flow = ConnectionUri::Flow::rtscts;
    else if (flow == "xonxoff") uri.flow = ConnectionUri::Flow::xonxoff;
    else return std::unexpected(fmt::format("flow '{}' is not one of none, rtscts, xonxoff", value));
  } else if (key == "terminator") {
    const std::string terminator = lower(value);
    if (terminator == "lf") uri.terminator = '\n';
    else if (terminator == "cr") uri.terminator = '\r';
    else return std::unexpected(fmt::format("terminator '{}' is not lf or cr", value));
  } else if (key == "pacing_ms") {
    const auto ms = parse_decimal(value, 0, kMaxPacingMs);
    if (!ms)
      return std::unexpected(fmt::format("pacing_ms '{}' is not a whole number from 0 to {}", value, kMaxPacingMs));
    uri.pacing_ms = static_cast<int>(*ms);
  }
  return {};
}

// Which query keys make sense: a TCP serial server has its line settings configured at the
// server, so only how commands are written is ours to choose there.
std::vector<std::string_view> allowed_keys(ConnectionUri::Scheme scheme) {
  if (scheme == ConnectionUri::Scheme::tcp) return {"terminator", "pacing_ms"};
  return {"baud", "flow", "terminator", "pacing_ms"};
}

std::expected<void, std::string> parse_query(ConnectionUri& uri, std::string_view query) {
  const auto allowed = allowed_keys(uri.scheme);
  std::set<std::string_view> seen;
  for (const auto pair : split(query, '&')) {
    if (pair.empty()) return std::unexpected("empty option in the query (a stray '&' or '?')");
    const auto equals = pair.find('=');
    if (equals == std::string_view::npos) return std::unexpected(fmt::format("option '{}' has no '=value'", pair));
    const auto key = pair.substr(0, equals), value = pair.substr(equals + 1);
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
      return std::unexpected(fmt::format("unknown option '{}'; this scheme accepts {}", key, fmt::join(allowed, ", ")));
    if (!seen.insert(key).second) return std::unexpected(fmt::format("option '{}' is given twice", key));
    if (value.empty()) return std::unexpected(fmt::format("option '{}' has an empty value", key));
    if (auto applied = apply_option(uri, key, value); !applied) return applied;
  }
  return {};
}

std::expected<void, std::string> parse_serial(ConnectionUri& uri, std::string_view rest) {
  if (rest.empty()) return std::unexpected("no device path; expected serial:/dev/ttyUSB0");
  uri.path = std::string(rest);
  return {};
}

std::expected<void, std::string> parse_port(ConnectionUri& uri, std::string_view digits) {
  const auto port = parse_decimal(digits, 1, 65535);
  if (!port) return std::unexpected(fmt::format("port '{}' is not a number from 1 to 65535", digits));
  uri.port = static_cast<unsigned short>(*port);
  return {};
}

// HOST:PORT, with an IPv6 address in brackets ([::1]:4001) since it has colons of its own.
std::expected<void, std::string> parse_tcp(ConnectionUri& uri, std::string_view rest) {
  if (rest.starts_with('[')) {
    const auto close = rest.find(']');
    if (close == std::string_view::npos) return std::unexpected("'[' without a closing ']' around the IPv6 address");
    uri.host = std::string(rest.substr(1, close - 1));
    if (uri.host.empty()) return std::unexpected("empty host in brackets");
    if (rest.substr(close + 1).empty() || rest[close + 1] != ':')
      return std::unexpected("no ':PORT' after the bracketed host; expected tcp:[::1]:4001");
    return parse_port(uri, rest.substr(close + 2));
  }
  const auto colon = rest.rfind(':');
  if (colon == std::string_view::npos) return std::unexpected("no port; expected tcp:HOST:PORT");
  const auto host = rest.substr(0, colon);
  if (host.empty()) return std::unexpected("no host; expected tcp:HOST:PORT");
  if (host.find(':') != std::string_view::npos)
    return std::unexpected(
        fmt::format("host '{}' has colons; put an IPv6 address in brackets, as tcp:[::1]:4001", host));
  uri.host = std::string(host);
  return parse_port(uri, rest.substr(colon + 1));
}

// VID:PID[:SERIAL]; the serial number is everything after the second colon.
std::expected<void, std::string> parse_usb(ConnectionUri& uri, std::string_view rest) {
  const auto first = rest.find(':');
  if (first == std::string_view::npos)
    return std::unexpected("expected usb:VID:PID[:SERIAL] with hex ids, as usb:067b:2303");
  const auto second = rest.find(':', first + 1);
  const auto vid_text = rest.substr(0, first);
  const auto pid_text =
      rest.substr(first + 1, second == std::string_view::npos ? std::string_view::npos : second - first - 1);
  const auto vid = parse_usb_id(vid_text), pid = parse_usb_id(pid_text);
  if (!vid) return std::unexpected(fmt::format("vendor id '{}' is not 1 to 4 hex digits", vid_text));
  if (!pid) return std::unexpected(fmt::format("product id '{}' is not 1 to 4 hex digits", pid_text));
  uri.vendor_id = *vid;
  uri.product_id = *pid;
  if (second != std::string_view::npos) {
    uri.usb_serial = std::string(rest.substr(second + 1));
    if (uri.usb_serial.empty()) return std::unexpected("empty serial number after 'VID:PID:'");
  }
  return {};
}

std::optional<ConnectionUri::Scheme> parse_scheme(std::string_view name) {
  const std::string scheme = lower(name);
  if (scheme == "serial") return ConnectionUri::Scheme::serial;
  if (scheme == "tcp") return ConnectionUri::Scheme::tcp;
  if (scheme == "usb") return ConnectionUri::Scheme::usb;
  return std::nullopt;
}

std::expected<void, std::string> parse_location(ConnectionUri& uri, std::string_view rest) {
  switch (uri.scheme) {
    case ConnectionUri::Scheme::serial:
      return parse_serial(uri, rest);
    case ConnectionUri::Scheme::tcp:
      return parse_tcp(uri, rest);
    case ConnectionUri::Scheme::usb:
      return parse_usb(uri, rest);
  }
  return {};
}

std::string query_string(const ConnectionUri& uri) {
  std::vector<std::string> options;
  if (uri.scheme != ConnectionUri::Scheme::tcp) {
    if (uri.baud != kDefaultBaud) options.push_back(fmt::format("baud={}", uri.baud));
    if (uri.flow == ConnectionUri::Flow::rtscts) options.emplace_back("flow=rtscts");
    if (uri.flow == ConnectionUri::Flow::xonxoff) options.emplace_back("flow=xonxoff");
  }
  if (uri.terminator) options.emplace_back(*uri.terminator == '\r' ? "terminator=cr" : "terminator=lf");
  if (uri.pacing_ms) options.push_back(fmt::format("pacing_ms={}", *uri.pacing_ms));
  return options.empty() ? std::string() : fmt::format("?{}", fmt::join(options, "&"));
}

}  // namespace

Parsed parse_connection_uri(std::string_view text) {
  if (text.empty()) return bad(text, "empty; expected serial:PATH, tcp:HOST:PORT or usb:VID:PID");
  if (std::any_of(text.begin(), text.end(), [](unsigned char c) { return std::isspace(c) || std::iscntrl(c); }))
    return bad(text, "contains spaces or control characters");
  const auto colon = text.find(':');
  if (colon == std::string_view::npos)
    return bad(text, "no scheme; expected serial:PATH, tcp:HOST:PORT or usb:VID:PID");
  const auto scheme = parse_scheme(text.substr(0, colon));
  if (!scheme) return bad(text, fmt::format("unknown scheme '{}'; expected serial, tcp or usb", text.substr(0, colon)));

  ConnectionUri uri;
  uri.scheme = *scheme;
  const auto rest = text.substr(colon + 1);
  const auto question = rest.find('?');
  if (auto located = parse_location(uri, rest.substr(0, question)); !located) return bad(text, located.error());
  if (question != std::string_view::npos)
    if (auto queried = parse_query(uri, rest.substr(question + 1)); !queried) return bad(text, queried.error());
  return uri;
}

std::string ConnectionUri::to_string() const {
  switch (scheme) {
    case Scheme::serial:
      return fmt::format("serial:{}{}", path, query_string(*this));
    case Scheme::tcp: {
      const bool ipv6 = host.find(':') != std::string::npos;
      return fmt::format("tcp:{}:{}{}", ipv6 ? "[" + host + "]" : host, port, query_string(*this));
    }
    case Scheme::usb: {
      const std::string serial = usb_serial.empty() ? std::string() : ":" + usb_serial;
      return fmt::format("usb:{:04x}:{:04x}{}{}", vendor_id, product_id, serial, query_string(*this));
    }
  }
  return {};
}

}  // namespace skinspec::drivers
