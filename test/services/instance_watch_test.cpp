// InstanceWatch: two live instances of one service are told from a restart by interleaved
// heartbeats. Heartbeat times are given, not waited for.
#include <gtest/gtest.h>

#include "fuse/service/instance_watch.hpp"

namespace fuse::service {
namespace {

using Clock = InstanceWatch::Clock;
const Clock::time_point t0{};
Clock::time_point at(double s) {
  return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

/// Heartbeats of `instance` every `period` s over [from, to].
void beat(InstanceWatch& w, const std::string& service, std::uint64_t instance, double from, double to,
          double period = 0.5) {
  for (double t = from; t <= to + 1e-9; t += period) w.heard(service, instance, at(t));
}

TEST(InstanceWatch, OneInstanceIsNoDuplicate) {
  InstanceWatch w(3.0);
  beat(w, "fuse-state", 1, 0.0, 10.0);
  EXPECT_TRUE(w.concurrent("fuse-state", at(10.0)).empty());
  EXPECT_TRUE(w.duplicates(at(10.0)).empty());
}

TEST(InstanceWatch, RestartsAreNotDuplicatesEvenWithALateHeartbeat) {
  InstanceWatch w(3.0);
  // Killed at 5.0; its last heartbeat (5.0) arrives after the new instance's first (4.9 is not
  // possible, but a heartbeat in flight may land after it): still a restart.
  beat(w, "fuse-state", 1, 0.0, 4.5);
  w.heard("fuse-state", 2, at(4.8));
  w.heard("fuse-state", 1, at(4.9));
  beat(w, "fuse-state", 2, 5.3, 8.0);
  for (double t : {4.9, 5.3, 6.0, 8.0}) EXPECT_TRUE(w.concurrent("fuse-state", at(t)).empty()) << t;
  // A restart loop (the chaos soak): kill and restart every 2 s.
  InstanceWatch chaos(3.0);
  for (int i = 0; i < 10; ++i) beat(chaos, "fuse-update", 100 + i, 2.0 * i, 2.0 * i + 1.5);
  EXPECT_TRUE(chaos.duplicates(at(20.0)).empty());
}

TEST(InstanceWatch, TwoAliveTogetherAreFoundWithinTwoHeartbeatsAndForgottenAfterTheWindow) {
  InstanceWatch w(3.0);
  beat(w, "fuse-ingest", 1, 0.0, 2.0);
  // The second starts at 2.25; from 2.75 each has two heartbeats after the other's first.
  w.heard("fuse-ingest", 2, at(2.25));
  w.heard("fuse-ingest", 1, at(2.5));
  EXPECT_TRUE(w.concurrent("fuse-ingest", at(2.5)).empty());
  w.heard("fuse-ingest", 2, at(2.75));
  w.heard("fuse-ingest", 1, at(3.0));
  const auto ids = w.concurrent("fuse-ingest", at(3.0));
  EXPECT_EQ(ids, (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(w.duplicates(at(3.0)).count("fuse-ingest"), 1u);
  EXPECT_TRUE(w.concurrent("fuse-state", at(3.0)).empty());
  // The second one stops at 3.25: once its heartbeats are older than the window, one is left.
  w.heard("fuse-ingest", 2, at(3.25));
  beat(w, "fuse-ingest", 1, 3.5, 5.0);
  EXPECT_FALSE(w.concurrent("fuse-ingest", at(5.0)).empty());
  beat(w, "fuse-ingest", 1, 5.5, 7.0);
  EXPECT_TRUE(w.concurrent("fuse-ingest", at(7.0)).empty());
  EXPECT_NE(describe_duplicate("fuse-ingest", ids).find("transport.system_name"), std::string::npos);
}

TEST(InstanceWatch, ServicesAreKeptApart) {
  InstanceWatch w(3.0);
  beat(w, "fuse-state", 1, 0.0, 5.0);
  beat(w, "fuse-update", 2, 0.0, 5.0);
  beat(w, "fuse-map", 3, 0.0, 5.0);
  EXPECT_TRUE(w.duplicates(at(5.0)).empty());
}

}  // namespace
}  // namespace fuse::service
