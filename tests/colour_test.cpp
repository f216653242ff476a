#include <gtest/gtest.h>
TEST(Colour, Placeholder) {}
