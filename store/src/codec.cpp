#include "codec.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>

#include "db.hpp"

namespace skinspec::store::detail {

namespace {

constexpr std::size_t kPairBytes = 16;

void put_double(char* out, double value) {
  auto bits = std::bit_cast<std::uint64_t>(value);
  if constexpr (std::endian::native == std::endian::big) bits = std::byteswap(bits);
  std::memcpy(out, &bits, sizeof bits);
}

double get_double(const char* in) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, in, sizeof bits);
  if constexpr (std::endian::native == std::endian::big) bits = std::byteswap(bits);
  return std::bit_cast<double>(bits);
}

[[noreturn]] void invalid(std::string message) { fail(StoreError::Kind::invalid_argument, std::move(message)); }

}  // namespace

std::string encode_spectrum(const SpectralSamples& spectrum) {
  std::string bytes(spectrum.wavelength_nm.size() * kPairBytes, '\0');
  for (std::size_t i = 0; i < spectrum.wavelength_nm.size(); ++i) {
    put_double(bytes.data() + i * kPairBytes, spectrum.wavelength_nm[i]);
    put_double(bytes.data() + i * kPairBytes + 8, spectrum.values[i]);
  }
  return bytes;
}

SpectralSamples decode_spectrum(std::string_view bytes, std::string_view what) {
  if (bytes.size() % kPairBytes != 0)
    fail(StoreError::Kind::corrupt,
         fmt::format("{}: {} bytes is not a whole number of (wavelength, value) pairs", what, bytes.size()));
  SpectralSamples spectrum;
  const std::size_t n = bytes.size() / kPairBytes;
  spectrum.wavelength_nm.resize(n);
  spectrum.values.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    spectrum.wavelength_nm[i] = get_double(bytes.data() + i * kPairBytes);
    spectrum.values[i] = get_double(bytes.data() + i * kPairBytes + 8);
  }
  return spectrum;
}

std::int64_t to_micros(Time time) { return time.time_since_epoch().count(); }
Time from_micros(std::int64_t micros) { return Time(std::chrono::microseconds(micros)); }

std::string encode_text_list(const std::vector<std::string>& items) {
  return nlohmann::json(items).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::vector<std::string> decode_text_list(std::string_view json, std::string_view what) {
  const auto parsed = nlohmann::json::parse(json, nullptr, false);
  if (parsed.is_discarded() || !parsed.is_array())
    fail(StoreError::Kind::corrupt, fmt::format("{}: not a JSON array of text", what));
  std::vector<std::string> items;
  for (const auto& item : parsed) {
    if (!item.is_string()) fail(StoreError::Kind::corrupt, fmt::format("{}: not a JSON array of text", what));
    items.push_back(item.get<std::string>());
  }
  return items;
}

namespace {

// `text` as a JSON string: as it is between quotes when nothing in it needs escaping (as a
// parameter's name never does), else as the JSON library writes it.
void append_json_string(std::string& out, std::string_view text) {
  const bool plain = std::ranges::all_of(text, [](char c) { return c >= 0x20 && c < 0x7f && c != '"' && c != '\\'; });
  if (!plain) {
    out += nlohmann::json(text).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    return;
  }
  out += '"';
  out += text;
  out += '"';
}

// The shortest text that reads back as `value`, with ".0" where it would read as an integer
// (which -0 would not survive); null for a value that is not finite.
void append_json_number(std::string& out, double value) {
  if (!std::isfinite(value)) {
    out += "null";
    return;
  }
  char text[32];
  const std::string_view written(std::begin(text), std::to_chars(std::begin(text), std::end(text), value).ptr);
  out += written;
  if (written.find_first_of(".e") == std::string_view::npos) out += ".0";
}

}  // namespace

// Written out directly: a refit stores thousands of fits a second, and building the array as
// JSON values first took as long as the insert.
std::string encode_fit_params(const std::vector<FitParam>& params) {
  std::string out = "[";
  for (const auto& p : params) {
    if (out.size() > 1) out += ',';
    out += R"({"name":)";
    append_json_string(out, p.name);
    out += R"(,"standard_error":)";
    append_json_number(out, p.standard_error);
    out += R"(,"value":)";
    append_json_number(out, p.value);
    out += '}';
  }
  out += ']';
  return out;
}

namespace {

// The members of a fit's parameter, each its own bit in the set of those read (other: none).
enum class ParamMember : unsigned { other = 0, name = 1, value = 2, standard_error = 4 };

constexpr unsigned bit(ParamMember m) { return static_cast<unsigned>(m); }

// A fit's parameters read as the parser meets them, without building the document: every read
// of a fit does this. The array's objects need "name" (a string), "value" (a number) and
// "standard_error" (a number, or null for one the spectrum does not determine); other members
// are passed over whatever they hold. Of a member given more than once only the last counts,
// as in a parsed document: a copy of the wrong kind is forgotten, not refused, and the
// parameter is judged when its object closes.
class FitParamsReader final : public nlohmann::json::json_sax_t {
 public:
  std::vector<FitParam> params;

  bool null() override { return scalar(Kind::null, 0); }
  bool boolean(bool) override { return scalar(Kind::other, 0); }
  bool number_integer(number_integer_t v) override { return scalar(Kind::number, static_cast<double>(v)); }
  bool number_unsigned(number_unsigned_t v) override { return scalar(Kind::number, static_cast<double>(v)); }
  bool number_float(number_float_t v, const string_t&) override { return scalar(Kind::number, v); }
  bool binary(binary_t&) override { return scalar(Kind::other, 0); }
  bool string(string_t& text) override {
    if (depth_ != 2 || member_ != Member::name) return scalar(Kind::other, 0);
    name_ = std::move(text);
    has_ |= bit(Member::name);
    return true;
  }
  bool key(string_t& name) override {
    if (depth_ == 2) member_ = member_named(name);
    return true;
  }
  bool start_object(std::size_t) override {
    if (depth_ == 1) has_ = 0;  // a parameter begins
    return opened(depth_ == 1);
  }
  bool end_object() override {
    if (--depth_ != 1) return true;
    if (has_ != kWhole) return false;  // a parameter ends without all it needs
    params.push_back({std::move(name_), value_, error_});
    return true;
  }
  bool start_array(std::size_t) override { return opened(depth_ == 0); }
  bool end_array() override {
    --depth_;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }

 private:
  using Member = ParamMember;
  enum class Kind { number, null, other };

  static constexpr unsigned kWhole = bit(Member::name) | bit(Member::value) | bit(Member::standard_error);

  static Member member_named(std::string_view name) {
    if (name == "name") return Member::name;
    if (name == "value") return Member::value;
    if (name == "standard_error") return Member::standard_error;
    return Member::other;
  }
  // An array or object: the array at the top and the parameters' objects in it, where the
  // shape needs them; as a member's value, or deeper, it is passed over (and is no valid
  // value of name, value or standard_error).
  bool opened(bool where_the_shape_needs_it) {
    if (depth_ == 2) has_ &= ~bit(member_);
    if (depth_ < 2 && !where_the_shape_needs_it) return false;
    ++depth_;
    return true;
  }
  // Any other value: a parameter's member, kept when of the member's kind and forgotten when
  // not; passed over deeper down; refused at the top and as an element of the array.
  bool scalar(Kind kind, double number) {
    if (depth_ > 2) return true;
    if (depth_ != 2) return false;
    const bool fits = (member_ == Member::value && kind == Kind::number) ||
                      (member_ == Member::standard_error && kind != Kind::other);
    if (!fits) {
      has_ &= ~bit(member_);
      return true;
    }
    if (member_ == Member::value) value_ = number;
    if (member_ == Member::standard_error)
      error_ = kind == Kind::null ? std::numeric_limits<double>::infinity() : number;
    has_ |= bit(member_);
    return true;
  }

  int depth_ = 0;
  Member member_ = Member::other;
  unsigned has_ = 0;
  std::string name_;
  double value_ = 0;
  double error_ = 0;
};

}  // namespace

std::vector<FitParam> decode_fit_params(std::string_view json, std::string_view what) {
  FitParamsReader reader;
  if (!nlohmann::json::sax_parse(json, &reader) || reader.params.empty())
    fail(StoreError::Kind::corrupt, fmt::format("{}: not a JSON array of {{name, value, standard_error}}", what));
  return std::move(reader.params);
}

std::string encode_job_error(const JobError& error) {
  const nlohmann::json object = {{"code", std::string(to_string(error.code))}, {"message", error.message}};
  return object.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

JobError decode_job_error(std::string_view json, std::string_view what) {
  const auto parsed = nlohmann::json::parse(json, nullptr, false);
  const auto text_at = [&](const char* key) -> const nlohmann::json* {
    if (!parsed.is_object()) return nullptr;
    const auto it = parsed.find(key);
    return it != parsed.end() && it->is_string() ? &*it : nullptr;
  };
  const auto* code_text = text_at("code");
  const auto* message = text_at("message");
  const auto code = code_text ? parse_job_error_code(code_text->get<std::string>()) : std::nullopt;
  if (!code || !message) fail(StoreError::Kind::corrupt, fmt::format("{}: not a job error skinspec writes", what));
  return {*code, message->get<std::string>()};
}

void check_spectrum(const SpectralSamples& spectrum, std::string_view what, bool may_be_empty) {
  const auto n = spectrum.wavelength_nm.size();
  if (n != spectrum.values.size())
    invalid(fmt::format("{}: {} wavelengths but {} values", what, n, spectrum.values.size()));
  if (n == 0 && !may_be_empty) invalid(fmt::format("{}: no samples", what));
  for (std::size_t i = 0; i < n; ++i) {
    const double w = spectrum.wavelength_nm[i];
    if (!std::isfinite(w)) invalid(fmt::format("{}: wavelength {} is not finite", what, i));
    if (i > 0 && !(w > spectrum.wavelength_nm[i - 1]))
      invalid(fmt::format("{}: wavelengths must strictly increase ({} nm after {} nm)", what, w,
                          spectrum.wavelength_nm[i - 1]));
  }
}

// One JSON object, alone but for whitespace (and a byte-order mark, which the JSON reader skips):
// checked by the reader everything the store keeps is read with, so that what is written can be
// read back.
void check_json_object(std::string_view json, std::string_view what) {
  std::string_view rest = json;
  if (rest.starts_with("\xEF\xBB\xBF")) rest.remove_prefix(3);
  const auto first = rest.find_first_not_of(" \t\n\r");
  if (first == std::string_view::npos || rest[first] != '{' || !nlohmann::json::accept(json))
    invalid(fmt::format("{}: not a JSON object", what));
}

void check_not_empty(std::string_view text, std::string_view what) {
  if (text.empty()) invalid(fmt::format("{} is empty", what));
}

}  // namespace skinspec::store::detail
