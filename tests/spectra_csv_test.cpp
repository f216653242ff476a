#include <gtest/gtest.h>
TEST(SpectraCsv, Placeholder) {}
