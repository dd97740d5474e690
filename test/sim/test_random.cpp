#include <gtest/gtest.h>

#include <cmath>

#include "fuse/sim/random.hpp"

using fuse::sim::Rng;
using fuse::sim::Stream;

TEST(SimRandom, SameSeedSameSequenceDifferentStreamsDiffer) {
  Rng a(42, Stream::kImu), b(42, Stream::kImu), c(42, Stream::kLidar), d(43, Stream::kImu);
  int same_c = 0, same_d = 0;
  for (int i = 0; i < 1000; ++i) {
    const double x = a.normal();
    EXPECT_EQ(x, b.normal());
    same_c += x == c.normal();
    same_d += x == d.normal();
  }
  EXPECT_EQ(same_c, 0);
  EXPECT_EQ(same_d, 0);
}

TEST(SimRandom, BoxMullerMomentsAndUniformRange) {
  Rng r(7, Stream::kMotion);
  const int n = 200000;
  double sum = 0, sum2 = 0, sum4 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    sum += x;
    sum2 += x * x;
    sum4 += x * x * x * x;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum2 / n, 1.0, 0.01);
  EXPECT_NEAR(sum4 / n, 3.0, 0.06);  // Gaussian kurtosis
  for (int i = 0; i < 10000; ++i) {
    const double u = r.uniform(2.0, 3.0);
    ASSERT_GE(u, 2.0);
    ASSERT_LT(u, 3.0);
    const int k = r.uniform_int(-2, 2);
    ASSERT_GE(k, -2);
    ASSERT_LE(k, 2);
  }
}
