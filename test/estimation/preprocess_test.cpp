// Step 1's range gate (PreprocessConfig::range_gate) and the preprocessing config's checks.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "fuse/estimation/estimator_config.hpp"
#include "../core/config_checks.hpp"

namespace fuse {
namespace {

TEST(RangeGate, PassesFinitePointsBetweenTheBoundsOnly) {
  PreprocessConfig c;
  c.min_range = 0.5;
  c.max_range = 60.0;
  const PreprocessConfig::RangeGate gate = c.range_gate();
  EXPECT_TRUE(gate.pass({0.5f, 0.0f, 0.0f}));  // the bounds belong to the range
  EXPECT_TRUE(gate.pass({0.0f, 0.0f, -60.0f}));
  EXPECT_TRUE(gate.pass({3.0f, -4.0f, 12.0f}));
  EXPECT_FALSE(gate.pass({0.3f, 0.3f, 0.0f}));
  EXPECT_FALSE(gate.pass({50.0f, 40.0f, 0.0f}));
  EXPECT_FALSE(gate.pass({0.0f, 0.0f, 0.0f}));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(gate.pass({nan, 1.0f, 1.0f}));
  EXPECT_FALSE(gate.pass({1.0f, inf, 1.0f}));
  EXPECT_FALSE(gate.pass({-inf, 0.0f, 0.0f}));
  EXPECT_FALSE(gate.pass({3e30f, 0.0f, 0.0f}));  // its square overflows to infinity
}

TEST(PreprocessConfig, RefusesBadValuesNamingTheKey) {
  expect_refused_naming_the_key<PreprocessConfig>(
      {"min_range: -1", "max_range: 0.1", "max_range: 5000", "voxel_size: 0", "max_points: 10"});
}

}  // namespace
}  // namespace fuse
