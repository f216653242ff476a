// The recording format: JSON lines, bytes as Latin-1 characters so that any byte survives.

#include "skinspec/simulator/recording.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace skinspec::simulator {

namespace {

using Json = nlohmann::ordered_json;

// Each byte becomes the character of the same number (U+0000-U+00FF), encoded in UTF-8.
std::string bytes_to_utf8(std::string_view bytes) {
  std::string out;
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    if (b < 0x80) {
      out += c;
    } else {
      out += static_cast<char>(0xC0 | (b >> 6));
      out += static_cast<char>(0x80 | (b & 0x3F));
    }
  }
  return out;
}

std::expected<std::string, std::string> utf8_to_bytes(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto b = static_cast<unsigned char>(text[i]);
    if (b < 0x80) {
      out += text[i];
      continue;
    }
    if ((b == 0xC2 || b == 0xC3) && i + 1 < text.size()) {
      const auto next = static_cast<unsigned char>(text[i + 1]);
      out += static_cast<char>(((b & 0x03) << 6) | (next & 0x3F));
      ++i;
      continue;
    }
    return std::unexpected("holds a character above U+00FF; every byte must be one character U+0000-U+00FF");
  }
  return out;
}

// Times to the microsecond; whole numbers print without a fraction.
Json time_value(double ms) {
  const double rounded = std::round(ms * 1000) / 1000;
  if (rounded == std::floor(rounded) && std::abs(rounded) < 1e12) return static_cast<std::int64_t>(rounded);
  return rounded;
}

struct Located {
  std::string_view source;
  std::size_t line;
  std::unexpected<std::string> operator()(std::string_view message) const {
    return std::unexpected(fmt::format("{}:{}: {}", source, line, message));
  }
};

std::expected<std::string, std::string> bytes_field(const Json& object, const char* key, const Located& at) {
  const auto it = object.find(key);
  if (it == object.end()) return at(fmt::format("missing \"{}\"", key));
  if (!it->is_string()) return at(fmt::format("\"{}\" is not a string", key));
  auto bytes = utf8_to_bytes(it->get_ref<const std::string&>());
  if (!bytes) return at(fmt::format("\"{}\" {}", key, bytes.error()));
  return bytes;
}

std::expected<double, std::string> time_field(const Json& object, const char* key, double fallback, const Located& at) {
  const auto it = object.find(key);
  if (it == object.end()) return fallback;
  if (!it->is_number() || !(it->get<double>() >= 0))
    return at(fmt::format("\"{}\" is not a number of milliseconds >= 0", key));
  return it->get<double>();
}

std::expected<RecordingHeader, std::string> parse_header(const Json& object, const Located& at) {
  static const std::vector<std::string> kKeys = {"format",      "version",       "model",          "captured", "by",
                                                 "description", "boot_window_s", "header_variant", "exp_char", "echo"};
  const auto format = object.find("format");
  const bool v2 = format != object.end() && format->is_string() && format->get<std::string>() == kRecordingFormat;
  const bool v1 = format != object.end() && format->is_string() && format->get<std::string>() == kRecordingFormatV1;
  if (!v1 && !v2)
    return at(fmt::format("the first line must be the header {{\"format\":\"{}\",\"version\":{},...}}",
                          kRecordingFormat, kRecordingVersion));
  for (const auto& [key, value] : object.items())
    if (std::ranges::find(kKeys, key) == kKeys.end()) return at(fmt::format("unknown header field \"{}\"", key));
  const auto version = object.find("version");
  if (version == object.end() || !version->is_number_integer()) return at("the header has no integer \"version\"");
  const int expected_version = v2 ? kRecordingVersion : 1;
  if (version->get<int>() != expected_version)
    return at(fmt::format("version {} is not one this reader knows (it reads version {} of \"{}\")",
                          version->get<int>(), expected_version, format->get<std::string>()));
  RecordingHeader header;
  const auto model = object.find("model");
  if (v2 && model == object.end()) return at("a version 2 header must name the \"model\"");
  if (v1 && model != object.end()) return at("a version 1 header has no \"model\": it is a PR-650 session");
  if (model != object.end()) {
    const auto known = model->is_string() ? drivers::model_from_id(model->get<std::string>()) : std::nullopt;
    if (!known) return at(fmt::format("\"model\" {} is not a model skinspec knows (pr650, pr655, ...)", model->dump()));
    header.model = *known;
  }
  const auto text = [&](const char* key, std::string& into) -> std::expected<void, std::string> {
    const auto it = object.find(key);
    if (it == object.end()) return {};
    if (!it->is_string()) return at(fmt::format("\"{}\" is not a string", key));
    into = it->get<std::string>();
    return {};
  };
  for (auto [key, into] : {std::pair{"captured", &header.captured}, std::pair{"by", &header.by},
                           std::pair{"description", &header.description}})
    if (auto ok = text(key, *into); !ok) return std::unexpected(ok.error());
  if (header.captured.empty()) return at("the header must say how the session was \"captured\"");
  if (const auto it = object.find("boot_window_s"); it != object.end()) {
    if (!it->is_number()) return at("\"boot_window_s\" is not a number");
    header.boot_window_s = it->get<double>();
  }
  if (const auto it = object.find("header_variant"); it != object.end()) {
    if (!it->is_string() || (*it != "H1" && *it != "H2")) return at("\"header_variant\" is neither \"H1\" nor \"H2\"");
    header.header_variant = it->get<std::string>();
  }
  if (const auto it = object.find("exp_char"); it != object.end()) {
    if (!it->is_string() || (*it != "E" && *it != "e")) return at("\"exp_char\" is neither \"E\" nor \"e\"");
    header.exponent = it->get<std::string>().front();
  }
  if (const auto it = object.find("echo"); it != object.end()) {
    if (!it->is_boolean()) return at("\"echo\" is not true or false");
    header.echo = it->get<bool>();
  }
  return header;
}

std::expected<std::vector<Fault>, std::string> parse_faults(const Json& value, const Located& at) {
  std::vector<std::string> texts;
  if (value.is_string()) {
    texts.push_back(value.get<std::string>());
  } else if (value.is_array() && std::ranges::all_of(value, [](const Json& v) { return v.is_string(); })) {
    for (const auto& v : value) texts.push_back(v.get<std::string>());
  } else {
    return at("\"fault\" is neither a string nor an array of strings");
  }
  std::vector<Fault> faults;
  for (const auto& text : texts) {
    auto fault = parse_fault(text);
    if (!fault) return at(fmt::format("\"fault\" '{}': {}", text, fault.error()));
    faults.push_back(*fault);
  }
  return faults;
}

std::expected<Exchange, std::string> parse_exchange(const Json& object, const Located& at) {
  static const std::vector<std::string> kKeys = {"tx", "rx", "delay_ms", "byte_interval_ms", "fault", "note"};
  for (const auto& [key, value] : object.items())
    if (std::ranges::find(kKeys, key) == kKeys.end())
      return at(fmt::format("unknown field \"{}\" (known: tx, rx, delay_ms, byte_interval_ms, fault, note)", key));
  Exchange exchange;
  auto tx = bytes_field(object, "tx", at);
  if (!tx) return std::unexpected(tx.error());
  auto rx = bytes_field(object, "rx", at);
  if (!rx) return std::unexpected(rx.error());
  exchange.tx = std::move(*tx);
  exchange.rx = std::move(*rx);
  auto delay = time_field(object, "delay_ms", 0, at);
  if (!delay) return std::unexpected(delay.error());
  auto interval = time_field(object, "byte_interval_ms", kLineByteIntervalMs, at);
  if (!interval) return std::unexpected(interval.error());
  exchange.delay_ms = *delay;
  exchange.byte_interval_ms = *interval;
  if (const auto it = object.find("fault"); it != object.end()) {
    auto faults = parse_faults(*it, at);
    if (!faults) return std::unexpected(faults.error());
    exchange.faults = std::move(*faults);
  }
  if (const auto it = object.find("note"); it != object.end()) {
    if (!it->is_string()) return at("\"note\" is not a string");
    exchange.note = it->get<std::string>();
  }
  return exchange;
}

}  // namespace

std::expected<Recording, std::string> parse_recording(std::string_view text, std::string_view source) {
  Recording recording;
  bool have_header = false;
  std::size_t number = 0;
  while (!text.empty()) {
    const auto lf = text.find('\n');
    std::string_view line = text.substr(0, lf);
    text.remove_prefix(lf == std::string_view::npos ? text.size() : lf + 1);
    ++number;
    const Located at{source, number};
    if (line.find_first_not_of(" \t\r") == std::string_view::npos) continue;
    Json object;
    try {
      object = Json::parse(line);
    } catch (const nlohmann::json::parse_error& error) {
      return at(fmt::format("not JSON: {}", error.what()));
    }
    if (!object.is_object()) return at("not a JSON object");
    if (!have_header) {
      auto header = parse_header(object, at);
      if (!header) return std::unexpected(header.error());
      recording.header = std::move(*header);
      have_header = true;
      continue;
    }
    auto exchange = parse_exchange(object, at);
    if (!exchange) return std::unexpected(exchange.error());
    recording.exchanges.push_back(std::move(*exchange));
  }
  if (!have_header) return std::unexpected(fmt::format("{}: empty: no header line", source));
  return recording;
}

std::string format_recording(const Recording& recording) {
  const RecordingHeader& h = recording.header;
  Json header;
  header["format"] = kRecordingFormat;
  header["version"] = kRecordingVersion;
  header["model"] = drivers::profile(h.model).id;
  header["captured"] = h.captured;
  header["by"] = h.by;
  if (!h.description.empty()) header["description"] = h.description;
  if (h.boot_window_s) header["boot_window_s"] = *h.boot_window_s;
  if (h.header_variant) header["header_variant"] = *h.header_variant;
  if (h.exponent) header["exp_char"] = std::string(1, *h.exponent);
  if (h.echo) header["echo"] = *h.echo;
  std::string out = header.dump() + "\n";
  for (const Exchange& e : recording.exchanges) {
    Json line;
    line["tx"] = bytes_to_utf8(e.tx);
    line["rx"] = bytes_to_utf8(e.rx);
    line["delay_ms"] = time_value(e.delay_ms);
    line["byte_interval_ms"] = time_value(e.byte_interval_ms);
    if (e.faults.size() == 1) line["fault"] = e.faults.front().to_string();
    if (e.faults.size() > 1) {
      Json faults = Json::array();
      for (const Fault& f : e.faults) faults.push_back(f.to_string());
      line["fault"] = std::move(faults);
    }
    if (!e.note.empty()) line["note"] = e.note;
    out += line.dump() + "\n";
  }
  return out;
}

}  // namespace skinspec::simulator
