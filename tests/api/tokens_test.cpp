// The named access tokens (api/src/tokens.cpp): their file in both formats, the files refused
// and why, the mode a token file must have, hashes and secrets, and the set a running service
// checks requests against, replaced while other threads read it.

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "skinspec/api/tokens.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::api {
namespace {

using testing::ScratchDirectory;

// A token file of `text` and `mode` in `dir`.
std::string token_file(const ScratchDirectory& dir, const std::string& text, mode_t mode = 0600) {
  const std::string path = dir.file("tokens.json");
  std::ofstream(path, std::ios::trunc) << text;
  ::chmod(path.c_str(), mode);
  return path;
}

std::string hex_of(const std::string& secret) { return to_hex(hash_token(secret)); }

TEST(Tokens, AreHashedWithSha256) {
  // FIPS 180-2's example.
  EXPECT_EQ(hex_of("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Tokens, ScopesAreOrderedReadMeasureAdmin) {
  EXPECT_TRUE(allows(Scope::admin, Scope::measure));
  EXPECT_TRUE(allows(Scope::admin, Scope::read));
  EXPECT_TRUE(allows(Scope::measure, Scope::read));
  EXPECT_TRUE(allows(Scope::measure, Scope::measure));
  EXPECT_FALSE(allows(Scope::read, Scope::measure));
  EXPECT_FALSE(allows(Scope::measure, Scope::admin));
  for (const Scope scope : kScopes) EXPECT_EQ(parse_scope(to_string(scope)), scope);
  EXPECT_EQ(parse_scope("operator"), std::nullopt);
  EXPECT_EQ(parse_scope("Admin"), std::nullopt);
  EXPECT_EQ(scope_names(), "read, measure or admin");
}

TEST(Tokens, NewSecretsAre32RandomBytesInBase64url) {
  std::set<std::string> seen;
  for (int i = 0; i < 100; ++i) {
    const std::string secret = new_token_secret();
    EXPECT_EQ(secret.size(), 43u) << secret;
    EXPECT_EQ(secret.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"),
              std::string::npos)
        << secret;
    seen.insert(secret);
  }
  EXPECT_EQ(seen.size(), 100u);
}

TEST(Tokens, TheNamedFormatGivesEachTokenItsNameAndScope) {
  const std::string text = R"({"tokens": [
    {"name": "ana", "scope": "measure", "sha256": ")" +
                           hex_of("ana-secret") + R"("},
    {"name": "lab-pc.2", "scope": "admin", "sha256": ")" +
                           hex_of("pc-secret") + R"("},
    {"name": "Viewer_1", "scope": "read", "sha256": ")" +
                           hex_of("viewer-secret") + R"("}]})";
  const auto file = parse_token_file(text, "t.json");
  ASSERT_TRUE(file) << file.error();
  EXPECT_EQ(file->format, TokenFileFormat::named);
  ASSERT_EQ(file->tokens.size(), 3u);
  EXPECT_EQ(file->tokens[0].name, "ana");
  EXPECT_EQ(file->tokens[0].scope, Scope::measure);
  EXPECT_EQ(file->tokens[0].sha256, hash_token("ana-secret"));
  EXPECT_EQ(file->tokens[1].scope, Scope::admin);
  EXPECT_EQ(file->tokens[2].scope, Scope::read);
  // Upper-case hexadecimal digits are the same hash.
  std::string upper = hex_of("x");
  for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  const auto shouted =
      parse_token_file(R"({"tokens": [{"name": "x", "scope": "read", "sha256": ")" + upper + "\"}]}", "t");
  ASSERT_TRUE(shouted) << shouted.error();
  EXPECT_EQ(shouted->tokens[0].sha256, hash_token("x"));
  // Every token revoked: a file the service reads, and then refuses everyone.
  const auto empty = parse_token_file(R"({"tokens": []})", "t.json");
  ASSERT_TRUE(empty) << empty.error();
  EXPECT_TRUE(empty->tokens.empty());
}

TEST(Tokens, TheOldTwoTokenFileIsReadAsReadAndOperator) {
  const auto file = parse_token_file(
      R"({"read_token": "read-0123456789abcdef", "operator_token": "oper-0123456789abcdef"})", "old.json");
  ASSERT_TRUE(file) << file.error();
  EXPECT_EQ(file->format, TokenFileFormat::legacy);
  ASSERT_EQ(file->tokens.size(), 2u);
  EXPECT_EQ(file->tokens[0].name, "read");
  EXPECT_EQ(file->tokens[0].scope, Scope::read);
  EXPECT_EQ(file->tokens[0].sha256, hash_token("read-0123456789abcdef"));
  // The old operator token could do everything.
  EXPECT_EQ(file->tokens[1].name, "operator");
  EXPECT_EQ(file->tokens[1].scope, Scope::admin);
  EXPECT_EQ(file->tokens[1].sha256, hash_token("oper-0123456789abcdef"));
}

// Each refusal names the file and what is wrong in it.
TEST(Tokens, ABadFileIsRefusedSayingWhereAndWhy) {
  const std::string good = hex_of("s1");
  const auto entry = [](const std::string& name, const std::string& scope, const std::string& hash) {
    return R"({"name": ")" + name + R"(", "scope": ")" + scope + R"(", "sha256": ")" + hash + R"("})";
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"not json", "lab.json: not a JSON object"},
      {"[]", "lab.json: not a JSON object"},
      {R"({"tokens": {}})", "lab.json: 'tokens' must be an array"},
      {R"({"tokens": [], "extra": 1})", "lab.json: unknown key 'extra'"},
      {R"({"tokens": [5]})", "lab.json: tokens[0]: not a JSON object"},
      {R"({"tokens": [)" + entry("ana", "operator", good) + "]}",
       "lab.json: tokens[0] ('ana'): 'scope' must be read, measure or admin"},
      {R"({"tokens": [)" + entry("ana", "read", good.substr(2)) + "]}",
       "lab.json: tokens[0] ('ana'): 'sha256' must be 64 hexadecimal digits"},
      {R"({"tokens": [)" + entry("ana", "read", "zz" + good.substr(2)) + "]}",
       "lab.json: tokens[0] ('ana'): 'sha256' must be 64 hexadecimal digits"},
      {R"({"tokens": [)" + entry("ana smith", "read", good) + "]}",
       "lab.json: tokens[0]: 'name' must be 1 to 64 letters"},
      {R"({"tokens": [)" + entry("", "read", good) + "]}", "lab.json: tokens[0]: 'name' must be 1 to 64 letters"},
      {R"({"tokens": [)" + entry(std::string(65, 'a'), "read", good) + "]}",
       "lab.json: tokens[0]: 'name' must be 1 to 64"},
      {R"({"tokens": [{"name": "ana", "scope": "read", "sha256": ")" + good + R"(", "secret": "x"}]})",
       "lab.json: tokens[0]: unknown field 'secret'"},
      {R"({"tokens": [)" + entry("ana", "read", good) + ", " + entry("ana", "admin", hex_of("s2")) + "]}",
       "lab.json: the name 'ana' is given to two tokens"},
      {R"({"tokens": [)" + entry("ana", "read", good) + ", " + entry("bo", "admin", good) + "]}",
       "lab.json: 'bo' has the hash of an earlier token"},
      {R"({"tokens": [], "read_token": "read-0123456789abcdef"})", "lab.json: give either 'tokens' or"},
      {R"({"read_token": "read-0123456789abcdef"})", "lab.json: 'operator_token' must be a string of at least 16"},
      {R"({"read_token": "short", "operator_token": "oper-0123456789abcdef"})",
       "lab.json: 'read_token' must be a string of at least 16"},
      {R"({"read_token": "same-0123456789abcdef", "operator_token": "same-0123456789abcdef"})",
       "lab.json: the two tokens must differ"},
  };
  for (const auto& [text, message] : cases) {
    const auto file = parse_token_file(text, "lab.json");
    ASSERT_FALSE(file) << text;
    EXPECT_EQ(file.error().rfind(message, 0), 0u) << text << "\n  gave: " << file.error();
  }
}

TEST(Tokens, AFileOthersMayReadOrWriteIsRefused) {
  ScratchDirectory dir;
  const std::string text = R"({"tokens": [{"name": "ana", "scope": "read", "sha256": ")" + hex_of("s") + "\"}]}";
  for (const mode_t mode : {0644, 0640, 0604, 0620, 0602, 0660}) {
    const auto path = token_file(dir, text, mode);
    const auto file = read_token_file(path);
    ASSERT_FALSE(file) << std::oct << mode;
    EXPECT_EQ(file.error(), path + ": the token file must be readable by its owner only (chmod 600)");
  }
  for (const mode_t mode : {0600, 0400}) {
    const auto file = read_token_file(token_file(dir, text, mode));
    ASSERT_TRUE(file) << std::oct << mode << ": " << file.error();
    EXPECT_EQ(file->tokens.at(0).name, "ana");
  }
  const auto missing = read_token_file(dir.file("absent.json"));
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().rfind(dir.file("absent.json") + ": cannot read the token file", 0), 0u) << missing.error();
  ::chmod(dir.path().c_str(), 0700);
  const auto directory = read_token_file(dir.path().string());
  ASSERT_FALSE(directory);
  EXPECT_EQ(directory.error(), dir.path().string() + ": the token file is not a regular file");
  const auto broken = read_token_file(token_file(dir, R"({"tokens": [)"));
  ASSERT_FALSE(broken);
  EXPECT_EQ(broken.error(), dir.file("tokens.json") + ": not a JSON object");
}

TEST(Tokens, AWrittenFileIsPrivateAndReadsBackTheSame) {
  ScratchDirectory dir;
  const std::vector<NamedToken> tokens = {{"ana", Scope::measure, hash_token("a")},
                                          {"pc", Scope::admin, hash_token("b")}};
  const std::string path = dir.file("tokens.json");
  ASSERT_TRUE(write_token_file(path, tokens));
  struct stat st{};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const auto back = read_token_file(path);
  ASSERT_TRUE(back) << back.error();
  ASSERT_EQ(back->tokens.size(), 2u);
  EXPECT_EQ(back->tokens[1].name, "pc");
  EXPECT_EQ(back->tokens[1].scope, Scope::admin);
  EXPECT_EQ(back->tokens[1].sha256, hash_token("b"));
  // Only hashes: neither secret is in the file.
  std::ifstream in(path);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  EXPECT_NE(text.find(hex_of("a")), std::string::npos) << text;
  // Replaced whole, and nothing left beside it.
  ASSERT_TRUE(write_token_file(path, {tokens[0]}));
  EXPECT_EQ(read_token_file(path)->tokens.size(), 1u);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), std::filesystem::directory_iterator()), 1);
  const auto nowhere = write_token_file(dir.file("no/such/dir/tokens.json"), tokens);
  ASSERT_FALSE(nowhere);
  EXPECT_NE(nowhere.error().find("no/such/dir/tokens.json: cannot write"), std::string::npos) << nowhere.error();
}

TEST(Tokens, TheKeyringKnowsCallersByTheirSecret) {
  const Keyring keyring({{"ana", Scope::measure, hash_token("ana-secret")}, {"bo", Scope::read, hash_token("bo")}});
  const auto ana = keyring.identify("ana-secret");
  ASSERT_TRUE(ana);
  EXPECT_EQ(ana->name, "ana");
  EXPECT_EQ(ana->scope, Scope::measure);
  EXPECT_EQ(keyring.identify("bo")->name, "bo");
  for (const char* wrong : {"", "ana-secre", "ana-secret ", "Ana-secret", "bo\n"})
    EXPECT_FALSE(keyring.identify(wrong)) << wrong;
  EXPECT_FALSE(Keyring({}).identify(""));
}

TEST(Tokens, AReplacedTokenIsRefusedOnTheNextCheck) {
  Keyring keyring({{"ana", Scope::measure, hash_token("ana-secret")}});
  keyring.replace({{"bo", Scope::admin, hash_token("bo-secret")}});
  EXPECT_FALSE(keyring.identify("ana-secret"));
  EXPECT_EQ(keyring.identify("bo-secret")->scope, Scope::admin);
  EXPECT_EQ(keyring.size(), 1u);
}

// Checks on several threads while the set is replaced again and again. One secret is ana's
// (measure) in one set and bo's (admin) in the other: each check finds one of the two whole,
// never nobody and never a name with the other's scope.
TEST(Tokens, ChecksDuringReplacementsSeeOneWholeSet) {
  const std::vector<NamedToken> first = {{"ana", Scope::measure, hash_token("s")}, {"x", Scope::read, hash_token("x")}};
  const std::vector<NamedToken> second = {{"bo", Scope::admin, hash_token("s")}};
  Keyring keyring(first);
  std::atomic<bool> stop{false};
  std::atomic<int> torn{0}, checks{0};
  std::vector<std::thread> readers;
  for (int t = 0; t < 3; ++t)
    readers.emplace_back([&] {
      while (!stop.load()) {
        const auto caller = keyring.identify("s");
        const bool whole = caller && ((caller->name == "ana" && caller->scope == Scope::measure) ||
                                      (caller->name == "bo" && caller->scope == Scope::admin));
        if (!whole) ++torn;
        ++checks;
      }
    });
  // Replaced until the readers, which a busy machine may start late, have checked often.
  for (int i = 0; i < 2000 || checks.load() < 1000; ++i) keyring.replace(i % 2 == 0 ? second : first);
  keyring.replace(first);
  stop = true;
  for (auto& r : readers) r.join();
  EXPECT_EQ(torn.load(), 0);
  EXPECT_GE(checks.load(), 1000);
  EXPECT_EQ(keyring.identify("s")->name, "ana");
}

}  // namespace
}  // namespace skinspec::api
