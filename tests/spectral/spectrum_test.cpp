#include "skinspec/spectral/spectrum.hpp"

#include <gtest/gtest.h>

namespace skinspec {
namespace {

TEST(Spectrum, RejectsNonIncreasingGrid) {
  EXPECT_FALSE(Spectrum::create({400, 400}, {1, 2}));
  EXPECT_FALSE(Spectrum::create({500, 400}, {1, 2}));
  EXPECT_FALSE(Spectrum::create({400}, {1}));
  EXPECT_FALSE(Spectrum::create({400, 500}, {1}));
  EXPECT_FALSE(Spectrum::create({400, 500}, {1, std::numeric_limits<double>::quiet_NaN()}));
  EXPECT_TRUE(Spectrum::create({400, 500}, {1, 2}));
}

TEST(Spectrum, InterpolatesLinearlyAndHoldsEnds) {
  const auto s = *Spectrum::create({400, 500, 600}, {1, 3, 2});
  EXPECT_DOUBLE_EQ(s.at(450), 2.0);
  EXPECT_DOUBLE_EQ(s.at(575), 2.25);
  EXPECT_DOUBLE_EQ(s.at(300), 1.0);
  EXPECT_DOUBLE_EQ(s.at(700), 2.0);
  const auto r = s.resampled(Spectrum::uniform_grid(400, 600, 50));
  ASSERT_EQ(r.size(), 5u);
  EXPECT_DOUBLE_EQ(r.values()[1], 2.0);
}

TEST(Spectrum, UniformGridIncludesTheLastPoint) {
  const auto g = Spectrum::uniform_grid(380, 780, 4);
  ASSERT_EQ(g.size(), 101u);
  EXPECT_DOUBLE_EQ(g.back(), 780);
}

TEST(Spectrum, ArithmeticResamplesTheOtherOperand) {
  const auto sample = *Spectrum::create({400, 500, 600}, {0.2, 0.4, 0.6});
  const auto white = *Spectrum::create({400, 600}, {0.8, 0.8});
  const auto ratio = sample / white * 0.99;
  EXPECT_DOUBLE_EQ(ratio.values()[1], 0.4 / 0.8 * 0.99);
  EXPECT_DOUBLE_EQ((sample * white).values()[2], 0.6 * 0.8);
}

}  // namespace
}  // namespace skinspec
