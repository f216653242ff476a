// The README's first command, scripts/demo, as a newcomer runs it after a build of only the
// three programs it needs: a directory holding skinspec, skinspecd and skinspec-sim and nothing
// else (no test or benchmark program) stands in for build/release/bin. The script must run its
// whole session from them, print the session with units, and say how long each phase took.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "skinspec/testkit/process.hpp"

namespace skinspec {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::Not;

const std::vector<std::string> kDemoPrograms = {"skinspec", "skinspecd", "skinspec-sim"};

// A scratch directory, removed with everything in it.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (fs::temp_directory_path() / "skinspec-demo-test.XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// The three programs alone in `bin`.
void copy_demo_programs(const fs::path& bin) {
  for (const auto& program : kDemoPrograms) fs::copy_file(fs::path(SKINSPEC_TEST_BIN_DIR) / program, bin / program);
}

testing::ProcessResult run_demo(const fs::path& bin) {
  return testing::run_process(
      "/bin/bash", {SKINSPEC_TEST_SOURCE_DIR "/scripts/demo"},
      testing::ProcessOptions{std::nullopt,
                              55s,
                              {"DEMO_SKIP_BUILD=1", "DEMO_EXIT=1", "DEMO_BIN_DIR=" + bin.string(),
                               "SKINSPEC_DATA_DIR=" SKINSPEC_TEST_DATA_DIR}});
}

TEST(DemoScript, RunsItsSessionWithOnlyTheThreeProgramsBuilt) {
  ScratchDir scratch;
  copy_demo_programs(scratch.path());

  const auto demo = run_demo(scratch.path());

  ASSERT_TRUE(demo.exited()) << demo.describe();
  ASSERT_EQ(demo.exit_status, 0) << demo.describe();
  EXPECT_THAT(demo.out, HasSubstr("white standard: measurement 1\n"));
  EXPECT_THAT(demo.out, HasSubstr("forearm 3: measurement 4, fit 3\n"));
  EXPECT_THAT(demo.out, ContainsRegex("session: +http://127\\.0\\.0\\.1:[0-9]+/api/v1/sessions/1\n"));
  // The session's fits as `skinspec session show` prints them, three rows.
  EXPECT_THAT(demo.out, ContainsRegex("\n +1 +2 +[^\n]*\n +2 +3 +[^\n]*\n +3 +4 +[^\n]*\n"));
  // The phases it ran, timed; no setup or build when told to skip them.
  EXPECT_THAT(demo.out, ContainsRegex("== wall time by phase\nsession +[0-9]+\\.[0-9] s\ntotal +[0-9]+\\.[0-9] s\n"));
  EXPECT_THAT(demo.out, Not(HasSubstr("\nbuild ")));
}

TEST(DemoScript, FailsAndSaysWhichProgramIsMissing) {
  ScratchDir scratch;
  copy_demo_programs(scratch.path());
  fs::remove(scratch.path() / "skinspecd");

  const auto demo = run_demo(scratch.path());

  ASSERT_TRUE(demo.exited()) << demo.describe();
  EXPECT_NE(demo.exit_status, 0) << demo.describe();
  EXPECT_THAT(demo.err, HasSubstr("skinspecd")) << demo.describe();
  EXPECT_THAT(demo.out, ContainsRegex("session \\(stopped\\) +[0-9]+\\.[0-9] s\n"));
}

}  // namespace
}  // namespace skinspec
