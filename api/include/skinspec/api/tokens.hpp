#pragma once
// Who may call skinspecd, and for what: named bearer tokens, one per person or program, each
// with a scope, kept in a file that holds only their SHA-256 hashes (docs/security.md). The
// router checks each request against them (router.cpp); `skinspec token` writes the file. A
// library of its own (skinspec::tokens), so that the command-line program needs neither Beast
// nor the routes to write it.

#include <array>
#include <cstdint>
#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec::api {

// What a token may do. Each scope may do all that the ones before it may, so the order of the
// enumerators is the order of the scopes (allows()).
enum class Scope : std::uint8_t {
  read,     // GET: everything there is to see
  measure,  // and the work of a bench: sessions, measurement, import, refit and map jobs, fits
  admin,    // and the lab's own records: white standards
};
inline constexpr std::array kScopes = {Scope::read, Scope::measure, Scope::admin};

std::string_view to_string(Scope scope);
std::optional<Scope> parse_scope(std::string_view name);
// "read, measure or admin", for messages.
std::string scope_names();
// Whether a token of scope `held` may call a route that needs `needed`.
constexpr bool allows(Scope held, Scope needed) { return held >= needed; }

using TokenHash = std::array<unsigned char, 32>;  // SHA-256

// The SHA-256 of a token's secret.
TokenHash hash_token(std::string_view secret);
std::string to_hex(const TokenHash& hash);

// A new token's secret: 32 bytes from the operating system's random generator, in base64url
// without padding (43 characters), safe in a header, a shell variable and a file.
std::string new_token_secret();

// 1 to 64 letters, digits, '.', '_' or '-': a name that reads the same in a log line.
bool valid_token_name(std::string_view name);

struct NamedToken {
  std::string name;
  Scope scope = Scope::read;
  TokenHash sha256{};
};

// Who made a request: the name and scope of the token it carried.
struct Caller {
  std::string name;
  Scope scope = Scope::read;
};

enum class TokenFileFormat {
  named,   // {"tokens": [{"name", "scope", "sha256"}]}
  legacy,  // {"read_token", "operator_token"}: the secrets themselves, read as "read" and "operator"
};

struct TokenFile {
  TokenFileFormat format = TokenFileFormat::named;
  std::vector<NamedToken> tokens;
};

// The tokens of a token file's text; the explanation of what is wrong with it, naming `path`.
std::expected<TokenFile, std::string> parse_token_file(std::string_view text, const std::string& path);
// Reads and parses the file at `path`, which only its owner may read or write (mode 0600 or
// stricter): a token file others can read gives away the legacy format's secrets, and one
// others can write lets them add tokens of their own.
std::expected<TokenFile, std::string> read_token_file(const std::string& path);
// The named format's text of `tokens`.
std::string token_file_text(const std::vector<NamedToken>& tokens);
// Writes `tokens` to `path` in the named format, mode 0600, in whole or not at all (a new file
// beside it renamed over it), so that a service reading it meanwhile sees the old file or the
// new one.
std::expected<void, std::string> write_token_file(const std::string& path, const std::vector<NamedToken>& tokens);

// The tokens a running service accepts. The set is replaced whole when the token file is read
// again (SIGHUP) while other threads check requests against it: each check sees the old set or
// the new one, and once replace() returns, no later check sees the old.
class Keyring {
 public:
  explicit Keyring(std::vector<NamedToken> tokens);

  // The caller whose token's secret is `secret`; nothing for an unknown one. The time it takes
  // depends on neither the secret nor which token matched.
  std::optional<Caller> identify(std::string_view secret) const;
  void replace(std::vector<NamedToken> tokens);
  std::size_t size() const;

 private:
  std::shared_ptr<const std::vector<NamedToken>> snapshot() const;

  mutable std::mutex mutex_;  // tokens_: the pointer, not what it points to, which never changes
  std::shared_ptr<const std::vector<NamedToken>> tokens_;
};

}  // namespace skinspec::api
