// The UTF-8 check and the printable form every message uses to quote input.

#include "skinspec/spectral/utf8.hpp"

#include <gtest/gtest.h>

#include <string>

namespace skinspec {
namespace {

struct Ill {
  const char* label;
  std::string bytes;
  std::size_t offset, length;
};

// Each ill-formed case of RFC 3629 and Unicode's table 3-7, after a valid prefix.
const Ill kIllFormed[] = {
    {"byte FF", "ab\xff", 2, 1},
    {"byte FE", "ab\xfe", 2, 1},
    {"F5 and above (past U+10FFFF)", "ab\xf5\x80\x80\x80", 2, 4},
    {"lone continuation byte", "ab\x80", 2, 1},
    {"continuation bytes after a whole sequence", "\xc3\xa9\xbf\xbf", 2, 2},
    {"overlong slash C0 AF", "ab\xc0\xaf", 2, 2},
    {"overlong C1 BF", "ab\xc1\xbf", 2, 2},
    {"overlong three bytes E0 80 AF", "ab\xe0\x80\xaf", 2, 3},
    {"overlong four bytes F0 80 80 AF", "ab\xf0\x80\x80\xaf", 2, 4},
    {"high surrogate ED A0 80", "ab\xed\xa0\x80", 2, 3},
    {"low surrogate ED BF BF", "ab\xed\xbf\xbf", 2, 3},
    {"past U+10FFFF F4 90 80 80", "ab\xf4\x90\x80\x80", 2, 4},
    {"truncated at the end", "ab\xe2\x82", 2, 2},
    {"truncated before ASCII", "ab\xe2\x82z", 2, 2},
    {"lead byte followed by a lead byte", "ab\xc3\xc3\xa9", 2, 1},
};

TEST(Utf8, FindsEveryIllFormedSequenceAndItsExtent) {
  for (const auto& [label, bytes, offset, length] : kIllFormed) {
    SCOPED_TRACE(label);
    const auto defect = utf8::first_defect(bytes);
    ASSERT_TRUE(defect);
    EXPECT_EQ(defect->offset, offset);
    EXPECT_EQ(defect->length, length);
    EXPECT_FALSE(utf8::is_valid(bytes));
  }
}

TEST(Utf8, AcceptsEveryWellFormedLength) {
  // ASCII, 2 bytes (é), 3 bytes (€, the last before the surrogates, the first after), 4 bytes
  // (an emoji, U+10000, U+10FFFF) and the byte order mark; all printed as they are.
  for (const std::string text : {"plain", "\xc3\xa9", "\xe2\x82\xac", "\xed\x9f\xbf", "\xee\x80\x80",
                                 "\xf0\x9f\x98\x80", "\xf0\x90\x80\x80", "\xf4\x8f\xbf\xbf", "\xef\xbb\xbf", ""}) {
    SCOPED_TRACE(text);
    EXPECT_FALSE(utf8::first_defect(text));
    EXPECT_EQ(printable(text).find('\\'), std::string::npos) << printable(text);
  }
}

TEST(Utf8, ControlCharactersAreUtf8ButNotPrintedAsThey) {
  const std::string controls("nul\0 esc\x1b", 9);
  EXPECT_TRUE(utf8::is_valid(controls));
  EXPECT_EQ(printable(controls), "nul\\x00 esc\\x1b");
}

TEST(Utf8, ALongRunOfBadBytesIsCutShort) {
  const auto defect = utf8::first_defect("ok" + std::string(100, '\xff'));
  ASSERT_TRUE(defect);
  EXPECT_EQ(defect->offset, 2u);
  EXPECT_EQ(defect->length, 16u);
}

TEST(Printable, EscapesControlsAndBadBytesAndKeepsText) {
  EXPECT_EQ(printable("a\tb\rc\nd"), "a\\tb\\rc\\nd");
  EXPECT_EQ(printable("\x1b[31mred\x1b[0m"), "\\x1b[31mred\\x1b[0m");
  EXPECT_EQ(printable(std::string("nul\0", 4)), "nul\\x00");
  EXPECT_EQ(printable("del\x7f"), "del\\x7f");
  EXPECT_EQ(printable("\xff\xfe"), "\\xff\\xfe");
  EXPECT_EQ(printable("\xc0\xaf"), "\\xc0\\xaf");
  EXPECT_EQ(printable("\xed\xa0\x80"), "\\xed\\xa0\\x80");
  // C1 controls (U+009B is a terminal's CSI) and the right-to-left override, as code points.
  EXPECT_EQ(printable("\xc2\x9b"
                      "2J"),
            "\\u009b2J");
  EXPECT_EQ(printable("abc\xe2\x80\xae"
                      "fdp.exe"),
            "abc\\u202efdp.exe");
  EXPECT_EQ(printable("Probandin \xc3\x84 \xe6\x97\xa5 \xf0\x9f\x98\x80"),
            "Probandin \xc3\x84 \xe6\x97\xa5 \xf0\x9f\x98\x80");
  EXPECT_EQ(quote("x\ty"), "'x\\ty'");
}

TEST(Printable, IsIdempotentSoAMessageMayBeMadeSafeTwice) {
  for (const std::string text : {"a\\b", "\xff\x1b\t", "\\xff", "\xe2\x80\xae", "ok"}) {
    SCOPED_TRACE(text);
    const auto once = printable(text);
    EXPECT_EQ(printable(once), once);
    EXPECT_TRUE(utf8::is_valid(once));
    for (const char c : once) EXPECT_GE(static_cast<unsigned char>(c), 0x20u) << once;
  }
}

}  // namespace
}  // namespace skinspec
