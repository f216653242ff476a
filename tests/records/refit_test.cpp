// Refits of stored measurements (records/refit.hpp) and `skinspec refit`: every measurement with
// a reflectance gets exactly one fit by the current model and constants, beside its earlier
// fits, however often the refit is stopped, killed and run again.

#include "skinspec/records/refit.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <map>
#include <random>

#include "skinspec/fit/model.hpp"
#include "skinspec/store/store.hpp"
#include "support/data.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::HasSubstr;
using testing::value_of;

constexpr int kBadInput = 2;

testing::ProcessResult skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

const std::vector<double>& grid() {
  static const auto g = Spectrum::uniform_grid(380, 780, 4);
  return g;
}

// Skin-like reflectances from the paper's model, light to dark, with a little noise.
std::vector<std::vector<double>> skin_reflectances(std::size_t count) {
  const auto& optics = testing::shipped_fitter().optics(ModelKind::paper);
  const SkinModel model(optics, *optics.site("forearm"), grid(), true);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> melanin(1, 20), blood(1, 6);
  std::normal_distribution<double> noise(0, 0.002);
  std::vector<std::vector<double>> out;
  for (std::size_t i = 0; i < count; ++i) {
    const double b = blood(random);
    auto r = model.reflectance({0.04, melanin(random), 0.8 * b, 0.2 * b, 0.5});
    for (double& v : r) v += noise(random);
    out.push_back(std::move(r));
  }
  return out;
}

class RefitTest : public ::testing::Test {
 protected:
  // Two sessions; each sample stored with a fit by another maker (an older version), and one
  // white reading without a reflectance, which has nothing to refit.
  void make_database(std::size_t samples) {
    auto store = value_of(Store::open(path_));
    sessions_ = {value_of(store.create_session(testing::sample_session(1))),
                 value_of(store.create_session(testing::sample_session(2)))};
    auto white = testing::sample_measurement(sessions_[0], 0);
    white.kind = MeasurementKind::white;
    white.reflectance = {};
    white_ = value_of(store.record_measurement(white, std::nullopt)).measurement_id;
    const auto reflectances = skin_reflectances(samples);
    for (std::size_t i = 0; i < samples; ++i) {
      auto m = testing::sample_measurement(sessions_[i % 2], static_cast<int>(i));
      m.reflectance = {grid(), reflectances[i]};
      samples_.push_back(value_of(store.record_measurement(m, testing::sample_fit(1))).measurement_id);
    }
  }

  // How many fits by the current maker each measurement holds, and how many fits in all.
  std::pair<std::map<Id, int>, int> fits_by_maker(const Store& store) const {
    const auto maker = records::current_fit_maker(testing::shipped_fitter(), ModelKind::extended);
    std::map<Id, int> current;
    int all = 0;
    for (const Id id : samples_) {
      for (const auto& f : value_of(store.fits_of_measurement(id))) {
        ++all;
        if (f.model == maker.model && f.model_version == maker.model_version &&
            f.tables_digest == maker.tables_digest && f.constants_digest == maker.constants_digest)
          ++current[id];
      }
    }
    return {current, all};
  }

  void expect_each_refitted_once() const {
    OpenOptions read_only;
    read_only.mode = OpenMode::read_only;
    const auto store = value_of(Store::open(path_, read_only));
    const auto [current, all] = fits_by_maker(store);
    EXPECT_EQ(current.size(), samples_.size()) << "a measurement was skipped";
    for (const auto& [id, count] : current) EXPECT_EQ(count, 1) << "measurement " << id << " refitted twice";
    EXPECT_EQ(all, static_cast<int>(2 * samples_.size())) << "an earlier fit went missing";
    EXPECT_TRUE(value_of(store.fits_of_measurement(white_)).empty());
  }

  testing::ScratchDirectory dir_;
  std::string path_ = dir_.file("lab.db");
  std::vector<Id> sessions_, samples_;
  Id white_ = 0;
};

TEST_F(RefitTest, EachMeasurementWithAReflectanceGetsOneFitBesideItsOldOnes) {
  make_database(40);
  {
    auto store = value_of(Store::open(path_));
    std::vector<records::RefitProgress> seen;
    const auto report = records::refit(store, testing::shipped_fitter(), {}, [&](const records::RefitProgress& p) {
      seen.push_back(p);
      return true;
    });
    ASSERT_TRUE(report) << report.error().message;
    EXPECT_FALSE(report->stopped);
    EXPECT_EQ(report->progress.total, 40);
    EXPECT_EQ(report->progress.done, 40);
    EXPECT_EQ(report->progress.failed, 0) << (report->failures.empty() ? "" : report->failures[0]);
    ASSERT_EQ(seen.size(), 1u);
    EXPECT_EQ(seen[0].done, 40);
    ASSERT_TRUE(seen[0].remaining_s);
    EXPECT_EQ(*seen[0].remaining_s, 0);
    // A fit as the service stores it: the session's site, the fitted curve, converged.
    const auto fits = value_of(store.fits_of_measurement(samples_[1]));
    ASSERT_EQ(fits.size(), 2u);
    EXPECT_EQ(fits[1].model, "extended");
    EXPECT_EQ(fits[1].site, value_of(store.session(sessions_[1])).site);
    EXPECT_EQ(fits[1].fitted.size(), grid().size());
    EXPECT_LT(fits[1].rmse, 0.02);
    // Run again, it finds nothing to do.
    const auto again = records::refit(store, testing::shipped_fitter(), {}, {});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->progress.total, 0);
  }
  expect_each_refitted_once();
}

TEST_F(RefitTest, OneSessionsRefitLeavesTheOtherSession) {
  make_database(10);
  auto store = value_of(Store::open(path_));
  records::RefitRequest request;
  request.session_id = sessions_[0];
  const auto report = records::refit(store, testing::shipped_fitter(), request, {});
  ASSERT_TRUE(report);
  EXPECT_EQ(report->progress.done, 5);
  EXPECT_EQ(value_of(store.fits_of_measurement(samples_[0])).size(), 2u);
  EXPECT_EQ(value_of(store.fits_of_measurement(samples_[1])).size(), 1u);
}

TEST_F(RefitTest, StoppedAfterABatchAndRunAgainEachMeasurementIsRefittedOnce) {
  make_database(2100);
  {
    auto store = value_of(Store::open(path_));
    int told = 0;
    const auto first = records::refit(store, testing::shipped_fitter(), {}, [&](const records::RefitProgress& p) {
      ++told;
      EXPECT_EQ(p.done, 512);  // of the first batch, stored first
      return false;
    });
    ASSERT_TRUE(first);
    EXPECT_TRUE(first->stopped);
    EXPECT_EQ(told, 1);
    // The batch told of, and the next if it was being stored then, counted; batches waiting
    // to be stored dropped (so, but for a disk that held the first batch up while several
    // were fitted, 512 or 1024).
    EXPECT_EQ(first->progress.done % 512, 0);
    EXPECT_GE(first->progress.done, 512);
    EXPECT_LT(first->progress.done, 2100);
    EXPECT_EQ(first->progress.total, 2100);
    const auto rest = records::refit(store, testing::shipped_fitter(), {}, {});
    ASSERT_TRUE(rest);
    EXPECT_EQ(rest->progress.total, 2100 - first->progress.done);
    EXPECT_EQ(rest->progress.done, 2100 - first->progress.done);
  }
  expect_each_refitted_once();
}

TEST_F(RefitTest, TheCommandRefitsAndSaysWhat) {
  make_database(12);
  const auto result = skinspec({"refit", "--db", path_});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_THAT(result.out, HasSubstr("refitted 12 of 12 measurements with the extended model"));
  EXPECT_THAT(result.err, HasSubstr("refit: 12 of 12 refitted"));
  const auto again = skinspec({"refit", "--db", path_});
  ASSERT_EQ(again.exit_status, 0) << again.describe();
  EXPECT_THAT(again.out, HasSubstr("refitted 0 of 0 measurements"));
  expect_each_refitted_once();
}

TEST_F(RefitTest, TheCommandRefusesWhatItCannotRefitWithStatus2) {
  make_database(2);
  const auto unknown_session = skinspec({"refit", "--db", path_, "--session", "99"});
  EXPECT_EQ(unknown_session.exit_status, kBadInput) << unknown_session.describe();
  EXPECT_THAT(unknown_session.err, HasSubstr("session 99 does not exist"));
  const auto missing = skinspec({"refit", "--db", dir_.file("none.db")});
  EXPECT_EQ(missing.exit_status, kBadInput) << missing.describe();
  EXPECT_FALSE(std::filesystem::exists(dir_.file("none.db")));
  {
    // skinspecd holds the database: the refit is refused, not run beside it.
    auto writer = value_of(Store::open(path_));
    const auto busy = skinspec({"refit", "--db", path_});
    EXPECT_EQ(busy.exit_status, kBadInput) << busy.describe();
    EXPECT_THAT(busy.err, HasSubstr(path_));
  }
  // A spectrum the fitter refuses (too short a range) is named, with status 2; the others are
  // stored, and the refused one is tried again on the next run.
  Id short_range = 0;
  {
    auto store = value_of(Store::open(path_));
    auto narrow = testing::sample_measurement(sessions_[0], 50);
    narrow.reflectance = {Spectrum::uniform_grid(500, 600, 4), std::vector<double>(26, 0.4)};
    short_range = value_of(store.record_measurement(narrow, std::nullopt)).measurement_id;
  }
  const auto refused = skinspec({"refit", "--db", path_});
  EXPECT_EQ(refused.exit_status, kBadInput) << refused.describe();
  EXPECT_THAT(refused.out, HasSubstr("refitted 2 of 3 measurements"));
  EXPECT_THAT(refused.err, HasSubstr("measurement " + std::to_string(short_range) + ": the spectrum must cover"));
  const auto again = skinspec({"refit", "--db", path_});
  EXPECT_EQ(again.exit_status, kBadInput) << again.describe();
  EXPECT_THAT(again.out, HasSubstr("refitted 0 of 1 measurements"));
  expect_each_refitted_once();
}

// Killed part way (SIGKILL after its first batch was stored), then run again: every measurement
// refitted exactly once, none skipped.
TEST_F(RefitTest, KilledMidRefitAndRunAgainEachMeasurementIsRefittedOnce) {
  make_database(3000);
  {
    testing::BackgroundProcess refit(SKINSPEC_TEST_BIN_DIR "/skinspec", {"refit", "--db", path_});
    ASSERT_TRUE(refit.started()) << refit.start_error();
    ASSERT_TRUE(refit.wait_for_stderr("refit: 512 of 3000", std::chrono::seconds(60))) << refit.err();
    refit.send_signal(SIGKILL);
    const auto ended = refit.wait(std::chrono::seconds(10));
    EXPECT_EQ(ended.signal, SIGKILL) << ended.describe();
  }
  // What the killed run stored (at least its first batch) the second run does not do again.
  std::size_t stored_before = 0;
  {
    OpenOptions read_only;
    read_only.mode = OpenMode::read_only;
    const auto store = value_of(Store::open(path_, read_only));
    stored_before = fits_by_maker(store).first.size();
  }
  EXPECT_GE(stored_before, 512u);
  EXPECT_LT(stored_before, 3000u) << "the refit ended before it was killed";
  const auto rest = skinspec({"refit", "--db", path_});
  ASSERT_EQ(rest.exit_status, 0) << rest.describe();
  const auto left = std::to_string(3000 - stored_before);
  EXPECT_THAT(rest.out, HasSubstr("refitted " + left + " of " + left + " measurements"));
  expect_each_refitted_once();
}

}  // namespace
}  // namespace skinspec
