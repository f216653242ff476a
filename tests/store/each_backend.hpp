#pragma once
// Store suites run on both engines: the name of each engine's instance of a suite.

#include <gtest/gtest.h>

#include <string>

#include "skinspec/store/store.hpp"

namespace skinspec::testing {

inline std::string backend_name(const ::testing::TestParamInfo<store::Backend>& info) {
  return info.param == store::Backend::sqlite ? "sqlite" : "postgresql";
}

}  // namespace skinspec::testing
