#include "skinspec/api/tokens.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <nlohmann/json.hpp>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

namespace skinspec::api {

using nlohmann::json;

namespace {

// The legacy format's secrets were checked for this length; a shorter one is refused as before.
constexpr std::size_t kLegacyMinLength = 16;

std::optional<TokenHash> parse_hex(std::string_view text) {
  TokenHash hash{};
  if (text.size() != hash.size() * 2) return std::nullopt;
  const auto digit = [](char ch) -> int {
    if (ch >= '0' && ch <= '9') return ch - '0';
    if (ch >= 'a' && ch <= 'f') return ch - 'a' + 10;
    if (ch >= 'A' && ch <= 'F') return ch - 'A' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < hash.size(); ++i) {
    const int high = digit(text[2 * i]), low = digit(text[2 * i + 1]);
    if (high < 0 || low < 0) return std::nullopt;
    hash[i] = static_cast<unsigned char>(high * 16 + low);
  }
  return hash;
}

std::string system_error(const std::string& what) { return what + ": " + std::strerror(errno); }

std::expected<TokenFile, std::string> parse_legacy(const json& file, const std::string& path) {
  TokenFile out;
  out.format = TokenFileFormat::legacy;
  // The old operator token could do everything, so it keeps doing everything.
  for (const auto& [key, name, scope] :
       {std::tuple{"read_token", "read", Scope::read}, std::tuple{"operator_token", "operator", Scope::admin}}) {
    const auto it = file.find(key);
    if (it == file.end() || !it->is_string() || it->get<std::string>().size() < kLegacyMinLength)
      return std::unexpected(path + ": '" + key + "' must be a string of at least 16 characters");
    out.tokens.push_back({name, scope, hash_token(it->get<std::string>())});
  }
  if (out.tokens[0].sha256 == out.tokens[1].sha256) return std::unexpected(path + ": the two tokens must differ");
  return out;
}

std::expected<NamedToken, std::string> parse_entry(const json& entry, const std::string& where) {
  if (!entry.is_object()) return std::unexpected(where + ": not a JSON object");
  for (const auto& item : entry.items())
    if (item.key() != "name" && item.key() != "scope" && item.key() != "sha256")
      return std::unexpected(where + ": unknown field '" + item.key() + "' (known: name, scope, sha256)");
  const auto text = [&entry](const char* key) -> std::optional<std::string> {
    const auto it = entry.find(key);
    if (it == entry.end() || !it->is_string()) return std::nullopt;
    return it->get<std::string>();
  };
  NamedToken token;
  const auto name = text("name");
  if (!name || !valid_token_name(*name))
    return std::unexpected(where + ": 'name' must be 1 to 64 letters, digits, '.', '_' or '-'");
  token.name = *name;
  const auto scope_name = text("scope");
  const auto scope = scope_name ? parse_scope(*scope_name) : std::nullopt;
  if (!scope) return std::unexpected(where + " ('" + token.name + "'): 'scope' must be " + scope_names());
  token.scope = *scope;
  const auto hex = text("sha256");
  const auto hash = hex ? parse_hex(*hex) : std::nullopt;
  if (!hash) return std::unexpected(where + " ('" + token.name + "'): 'sha256' must be 64 hexadecimal digits");
  token.sha256 = *hash;
  return token;
}

std::expected<TokenFile, std::string> parse_named(const json& file, const std::string& path) {
  for (const auto& item : file.items())
    if (item.key() != "tokens") return std::unexpected(path + ": unknown key '" + item.key() + "' (known: tokens)");
  const json& list = file["tokens"];
  if (!list.is_array()) return std::unexpected(path + ": 'tokens' must be an array");
  TokenFile out;
  std::set<std::string> names;
  std::set<TokenHash> hashes;
  for (std::size_t i = 0; i < list.size(); ++i) {
    auto token = parse_entry(list[i], path + ": tokens[" + std::to_string(i) + "]");
    if (!token) return std::unexpected(token.error());
    if (!names.insert(token->name).second)
      return std::unexpected(path + ": the name '" + token->name + "' is given to two tokens");
    // Two names for one secret would leave it unknown which of them made a request.
    if (!hashes.insert(token->sha256).second)
      return std::unexpected(path + ": '" + token->name + "' has the hash of an earlier token");
    out.tokens.push_back(std::move(*token));
  }
  return out;
}

}  // namespace

std::string_view to_string(Scope scope) {
  switch (scope) {
    case Scope::read:
      return "read";
    case Scope::measure:
      return "measure";
    case Scope::admin:
      return "admin";
  }
  return "admin";
}

std::optional<Scope> parse_scope(std::string_view name) {
  for (const Scope scope : kScopes)
    if (to_string(scope) == name) return scope;
  return std::nullopt;
}

std::string scope_names() {
  std::string out;
  for (std::size_t i = 0; i < kScopes.size(); ++i)
    out += std::string(i == 0 ? "" : i + 1 == kScopes.size() ? " or " : ", ") + std::string(to_string(kScopes[i]));
  return out;
}

TokenHash hash_token(std::string_view secret) {
  TokenHash hash{};
  unsigned int length = 0;
  if (EVP_Digest(secret.data(), secret.size(), hash.data(), &length, EVP_sha256(), nullptr) != 1 ||
      length != hash.size())
    throw std::runtime_error("SHA-256 failed");
  return hash;
}

std::string to_hex(const TokenHash& hash) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (const unsigned char byte : hash) {
    out += kDigits[byte >> 4];
    out += kDigits[byte & 0xf];
  }
  return out;
}

std::string new_token_secret() {
  std::array<unsigned char, 32> bytes{};
  if (RAND_bytes(bytes.data(), static_cast<int>(bytes.size())) != 1)
    throw std::runtime_error("the system's random generator gave no bytes");
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  std::string out;
  std::uint32_t bits = 0;
  int held = 0;
  for (const unsigned char byte : bytes) {
    bits = (bits << 8) | byte;
    held += 8;
    while (held >= 6) {
      held -= 6;
      out += kAlphabet[(bits >> held) & 0x3f];
    }
  }
  if (held > 0) out += kAlphabet[(bits << (6 - held)) & 0x3f];
  OPENSSL_cleanse(bytes.data(), bytes.size());
  return out;
}

bool valid_token_name(std::string_view name) {
  return !name.empty() && name.size() <= 64 && std::ranges::all_of(name, [](char ch) {
    return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '.' || ch == '_' ||
           ch == '-';
  });
}

std::expected<TokenFile, std::string> parse_token_file(std::string_view text, const std::string& path) {
  const json file = json::parse(text, nullptr, false);
  if (file.is_discarded() || !file.is_object()) return std::unexpected(path + ": not a JSON object");
  const bool named = file.contains("tokens");
  const bool legacy = file.contains("read_token") || file.contains("operator_token");
  if (named && legacy)
    return std::unexpected(path + ": give either 'tokens' or 'read_token' and 'operator_token', not both");
  return named ? parse_named(file, path) : parse_legacy(file, path);
}

std::expected<TokenFile, std::string> read_token_file(const std::string& path) {
  struct stat st{};
  if (::stat(path.c_str(), &st) != 0) return std::unexpected(system_error(path + ": cannot read the token file"));
  if (!S_ISREG(st.st_mode)) return std::unexpected(path + ": the token file is not a regular file");
  if ((st.st_mode & 077) != 0)
    return std::unexpected(path + ": the token file must be readable by its owner only (chmod 600)");
  std::ifstream in(path);
  if (!in) return std::unexpected(system_error(path + ": cannot read the token file"));
  std::stringstream bytes;
  bytes << in.rdbuf();
  return parse_token_file(bytes.str(), path);
}

std::string token_file_text(const std::vector<NamedToken>& tokens) {
  json list = json::array();
  for (const auto& t : tokens)
    list.push_back({{"name", t.name}, {"scope", to_string(t.scope)}, {"sha256", to_hex(t.sha256)}});
  return json{{"tokens", list}}.dump(2) + "\n";
}

std::expected<void, std::string> write_token_file(const std::string& path, const std::vector<NamedToken>& tokens) {
  const std::string text = token_file_text(tokens);
  std::string temporary = path + ".XXXXXX";
  const int fd = ::mkstemp(temporary.data());  // mode 0600
  if (fd < 0) return std::unexpected(system_error(path + ": cannot write beside the token file"));
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  const bool ok = written == text.size() && ::fsync(fd) == 0;
  const std::string failure = ok ? std::string() : system_error(temporary + ": cannot write");
  ::close(fd);
  if (!ok || ::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string message = ok ? system_error(path + ": cannot replace the token file") : failure;
    ::unlink(temporary.c_str());
    return std::unexpected(message);
  }
  // The rename itself survives a power cut only once the directory is on disk.
  const auto parent = std::filesystem::path(path).parent_path();
  const int dir = ::open(parent.empty() ? "." : parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
  return {};
}

Keyring::Keyring(std::vector<NamedToken> tokens)
    : tokens_(std::make_shared<const std::vector<NamedToken>>(std::move(tokens))) {}

std::shared_ptr<const std::vector<NamedToken>> Keyring::snapshot() const {
  const std::lock_guard lock(mutex_);
  return tokens_;
}

std::optional<Caller> Keyring::identify(std::string_view secret) const {
  const auto tokens = snapshot();
  // The secret is hashed and every hash compared in constant time, without stopping at a
  // match: how long a check takes tells nothing of how much of a secret was right, or whose.
  const TokenHash presented = hash_token(secret);
  const NamedToken* found = nullptr;
  for (const NamedToken& token : *tokens)
    if (CRYPTO_memcmp(token.sha256.data(), presented.data(), presented.size()) == 0) found = &token;
  if (found == nullptr) return std::nullopt;
  return Caller{found->name, found->scope};
}

void Keyring::replace(std::vector<NamedToken> tokens) {
  auto next = std::make_shared<const std::vector<NamedToken>>(std::move(tokens));
  const std::lock_guard lock(mutex_);
  tokens_.swap(next);
}

std::size_t Keyring::size() const { return snapshot()->size(); }

}  // namespace skinspec::api
