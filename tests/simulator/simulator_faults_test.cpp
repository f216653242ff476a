// The fault grammar COMMAND:FAULT[=VALUE][@N[+]] and which commands a plan hits.

#include "skinspec/simulator/faults.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

namespace skinspec::simulator {
namespace {

using ::testing::HasSubstr;

FaultSpec spec(std::string_view text) {
  auto parsed = parse_fault_spec(text);
  EXPECT_TRUE(parsed) << text << ": " << parsed.error();
  return parsed.value_or(FaultSpec{});
}

TEST(FaultSpec, ParsesCommandFaultValueAndOccurrence) {
  const FaultSpec truncate = spec("d5:truncate");
  EXPECT_EQ(truncate.command, "d5");
  EXPECT_EQ(truncate.fault.kind, FaultKind::truncate);
  EXPECT_LT(truncate.fault.amount, 0);
  EXPECT_EQ(truncate.at, 0);

  const FaultSpec second = spec("m0:no-answer@2");
  EXPECT_EQ(second.fault.kind, FaultKind::no_answer);
  EXPECT_EQ(second.at, 2);
  EXPECT_FALSE(second.onwards);

  const FaultSpec onwards = spec(" M:Quality=18@3+ ");
  EXPECT_EQ(onwards.command, "m");
  EXPECT_EQ(onwards.fault.kind, FaultKind::quality);
  EXPECT_EQ(onwards.fault.amount, 18);
  EXPECT_TRUE(onwards.onwards);

  EXPECT_EQ(spec("*:garbage").command, "*");
  EXPECT_EQ(spec("b:late=250.5").fault.amount, 250.5);
  EXPECT_EQ(spec("e:exponent=E").fault.exponent, 'E');
  EXPECT_EQ(spec("d5:header=H1").fault.header, drivers::pr650::HeaderVariant::h1_bare_cr);
  EXPECT_EQ(spec("d5:drop_line").fault.kind, FaultKind::drop_line);
  EXPECT_EQ(spec("d110:line-count=0").fault.amount, 0);
}

TEST(FaultSpec, PrintsBackToAnEquivalentSpec) {
  for (const std::string text : {"d5:truncate", "m0:no-answer@2", "m:quality=18@3+", "*:garbage=4", "d5:header=h1",
                                 "*:exponent=e", "b:late=250.5", "d5:disconnect=800", "m0:stale=10", "m0:reboot@5"})
    EXPECT_EQ(spec(text).to_string(), text);
}

TEST(FaultSpec, RefusesMalformedSpecsSayingWhy) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"d5", "expected COMMAND:FAULT"},
      {"x5:truncate", "'x5' is not a meter command"},
      {"s1:truncate", "'s1' is not a meter command"},
      {":truncate", "is not a meter command"},
      {"d5:trunc", "unknown fault 'trunc' (known: no-answer, late, truncate"},
      {"d5:", "no fault named"},
      {"m0:quality", "'quality' needs a value"},
      {"m0:quality=100", "not an integer 0-99"},
      {"m0:no-answer=3", "'no-answer' takes no value"},
      {"d5:truncate=", "lacks its value"},
      {"d5:truncate=-3", "not an integer"},
      {"d5:truncate@0", "not a count of 1 or more"},
      {"d5:truncate@x", "not a count"},
      {"d5:exponent=x", "neither 'e' nor 'E'"},
      {"d5:header=h3", "neither 'h1' nor 'h2'"},
      {"d5:late=soon", "not a delay"},
      {"d5:line-count", "needs a value"},
  };
  for (const auto& [text, message] : cases) {
    auto parsed = parse_fault_spec(text);
    ASSERT_FALSE(parsed) << text;
    EXPECT_THAT(parsed.error(), HasSubstr(message)) << text;
    EXPECT_THAT(parsed.error(), HasSubstr("fault '" + text + "'")) << text;
  }
}

TEST(FaultSpec, MatchesByLetterCodeOrAnything) {
  EXPECT_TRUE(spec("m:truncate").matches("m0"));
  EXPECT_TRUE(spec("m:truncate").matches("m5"));
  EXPECT_FALSE(spec("m:truncate").matches("d5"));
  EXPECT_TRUE(spec("d1:truncate").matches("d1"));
  EXPECT_FALSE(spec("d1:truncate").matches("d110"));
  EXPECT_TRUE(spec("*:truncate").matches("s"));
}

TEST(FaultPlan, CountsTheCommandsEachSpecMatches) {
  auto plan = FaultPlan::parse(std::vector<std::string>{"m0:no-answer@2", "d5:truncate@2+", "*:late=5@3"});
  ASSERT_TRUE(plan) << plan.error();
  const auto kinds = [&](std::string_view key) {
    std::vector<FaultKind> out;
    for (const auto& f : plan->next(key)) out.push_back(f.kind);
    return out;
  };
  using K = FaultKind;
  EXPECT_EQ(kinds("m0"), std::vector<K>{});
  EXPECT_EQ(kinds("d5"), std::vector<K>{});
  EXPECT_EQ(kinds("m0"), (std::vector<K>{K::no_answer, K::late}));
  EXPECT_EQ(kinds("d5"), std::vector<K>{K::truncate});
  EXPECT_EQ(kinds("m0"), std::vector<K>{});
  EXPECT_EQ(kinds("d5"), std::vector<K>{K::truncate});
}

TEST(FaultPlan, RefusesAProbabilityOutsideZeroToOneAndNamesABadSpec) {
  EXPECT_FALSE(FaultPlan::parse({}, 1.5));
  EXPECT_FALSE(FaultPlan::parse({}, -0.1));
  EXPECT_FALSE(FaultPlan::parse({}, 0.5, 1, -1));
  auto plan = FaultPlan::parse(std::vector<std::string>{"d5:truncate", "d5:oops"});
  ASSERT_FALSE(plan);
  EXPECT_THAT(plan.error(), HasSubstr("d5:oops"));
}

TEST(FaultPlan, RandomModeIsSeededAndNeverEndsTheSession) {
  FaultPlan a({}, 1.0, 7), b({}, 1.0, 7), c({}, 1.0, 8);
  std::set<FaultKind> seen;
  bool differs = false;
  for (int i = 0; i < 2000; ++i) {
    const char* key = i % 2 ? "m0" : "d5";
    const auto fa = a.next(key), fb = b.next(key), fc = c.next(key);
    ASSERT_EQ(fa.size(), 1u);
    EXPECT_EQ(fa.front().to_string(), fb.front().to_string());
    differs |= fa.front().to_string() != fc.front().to_string();
    seen.insert(fa.front().kind);
    if (fa.front().kind == FaultKind::quality) {
      EXPECT_EQ(key, std::string("m0"));
    }
  }
  EXPECT_TRUE(differs);
  EXPECT_FALSE(seen.contains(FaultKind::disconnect));
  EXPECT_FALSE(seen.contains(FaultKind::reboot));
  EXPECT_TRUE(seen.contains(FaultKind::quality));
  EXPECT_TRUE(seen.contains(FaultKind::no_answer));

  FaultPlan some({}, 0.25, 1);
  int hits = 0;
  for (int i = 0; i < 4000; ++i) hits += !some.next("b3").empty();
  EXPECT_NEAR(hits / 4000.0, 0.25, 0.03);
  EXPECT_TRUE(FaultPlan().empty());
}

TEST(FaultPlan, AGapSparesTheCommandsAfterARandomFault) {
  // Every command would get a fault; a gap of 1 leaves every second one alone, a gap of 2 two
  // in three. Faults asked for by spec are not spared.
  for (const int gap : {1, 2}) {
    auto plan = FaultPlan::parse(std::vector<std::string>{"d1:late=0"}, 1.0, 3, gap);
    ASSERT_TRUE(plan) << plan.error();
    for (int i = 0; i < 30; ++i) {
      const auto faults = plan->next("d1");
      const bool random = i % (gap + 1) == 0;
      ASSERT_EQ(faults.size(), random ? 2u : 1u) << "gap " << gap << ", command " << i;
      EXPECT_EQ(faults.front().to_string(), "late=0");
    }
  }
  // At a realistic rate no two faults are ever adjacent.
  auto plan = FaultPlan::parse({}, 0.3, 5, 1);
  bool previous = false;
  int hits = 0;
  for (int i = 0; i < 4000; ++i) {
    const bool hit = !plan->next("s").empty();
    EXPECT_FALSE(hit && previous) << "command " << i;
    previous = hit;
    hits += hit;
  }
  EXPECT_GT(hits, 500);
}

}  // namespace
}  // namespace skinspec::simulator
