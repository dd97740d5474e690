// HostClockMap: the sensor-to-host clock offset is the fastest sample's within the window.
#include "fuse/core/host_clock.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fuse {
namespace {

TEST(HostClockMap, UnknownBeforeTheFirstSample) {
  HostClockMap map;
  EXPECT_FALSE(map.offsets(0.0));
  map.observe(std::nan(""), 1.0);
  EXPECT_FALSE(map.offsets(0.0));
}

// Known truth: host = sensor + 1000 s, each sample late by a random 1..20 ms, except one in 50
// that comes through in 0.1 ms. The offset found is within that fastest latency of the truth.
TEST(HostClockMap, TheFastestSampleBoundsTheError) {
  constexpr double kOffset = 1000.0;
  HostClockMap map(10.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> latency(1e-3, 20e-3);
  for (int i = 0; i < 2000; ++i) {
    const double t = 0.005 * i;
    map.observe(t, t + kOffset + (i % 50 == 0 ? 1e-4 : latency(rng)));
  }
  const auto o = map.offsets(50.0);
  ASSERT_TRUE(o);
  EXPECT_NEAR(o->monotonic, kOffset + 1e-4, 1e-9);
  EXPECT_NEAR(o->realtime, kOffset + 1e-4 + 50.0, 1e-9);
}

// A fast sample older than the window no longer holds the minimum: a sensor clock that drifts
// 1 ms/s is followed to within the drift over one window.
TEST(HostClockMap, ADriftingClockIsFollowedWithinAWindow) {
  HostClockMap map(10.0);
  for (int i = 0; i <= 6000; ++i) {
    const double t = 0.01 * i;
    map.observe(t, t * 1.001 + 5.0 + 2e-3);
  }
  const double truth_now = 60.0 * 0.001 + 5.0 + 2e-3;
  EXPECT_NEAR(map.offsets(0.0)->monotonic, truth_now, 10.0 * 0.001 + 1e-4);
  EXPECT_GT(map.offsets(0.0)->monotonic, 5.0 + 2e-3 + 0.04);  // not the minimum of all time
}

// A sensor clock stepped back (a re-based stream) starts the window again from the new base; a
// sample re-delivered a little behind the newest is ignored.
TEST(HostClockMap, AClockStepBackStartsAgain) {
  HostClockMap map(10.0);
  for (int i = 0; i < 100; ++i) map.observe(100.0 + 0.01 * i, 200.0 + 0.01 * i);
  EXPECT_NEAR(map.offsets(0.0)->monotonic, 100.0, 1e-9);
  map.observe(100.5, 199.0);  // re-delivered late: not a measurement of the offset
  EXPECT_NEAR(map.offsets(0.0)->monotonic, 100.0, 1e-9);
  map.observe(1.0, 202.0);
  EXPECT_NEAR(map.offsets(0.0)->monotonic, 201.0, 1e-9);
}

TEST(HostClockMap, ObservingNowGivesTheHostClocks) {
  HostClockMap map;
  const double before = HostClockMap::now_monotonic();
  map.observe_now(5.0);
  const auto o = map.offsets_now();
  ASSERT_TRUE(o);
  EXPECT_GE(o->monotonic, before - 5.0);
  EXPECT_LT(o->monotonic, HostClockMap::now_monotonic() - 5.0 + 1e-9);
  // CLOCK_REALTIME is UNIX time: after 2020 on any machine that runs this.
  EXPECT_GT(o->realtime + 5.0, 1.58e9);
}

}  // namespace
}  // namespace fuse
