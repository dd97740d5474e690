// Temporal role: a LiDAR scan that arrives late relative to the IMU (after newer IMU samples,
// up to 200 ms) is applied at its own time through the state history, and the later IMU is
// re-propagated from the corrected entry; the trajectory equals on-time processing. A scan older
// than one already processed is refused and counted (no rollback).
#include <gtest/gtest.h>

#include <deque>
#include <filesystem>
#include <map>
#include <optional>

#include "fuse/estimation/estimator.hpp"
#include "fuse/io/sensor_source.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

const std::string kData = std::string(FUSE_TEST_DATA) + "/corridor60";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

/// Replays the recording with every scan handed to the estimator `delay` seconds after its end
/// (i.e. after the IMU samples of that interval); returns the pose at each scan end.
std::map<double, Eigen::Vector3d> replay(double delay, std::map<std::string, std::uint64_t>* counts = nullptr,
                                         bool reversed_pair = false) {
  RunnerConfig config = load_runner_config(kConfig);
  auto source = io::open_sensor_source(kData + "/recording.mcap");
  if (auto T = source->T_imu_lidar()) config.estimator.T_imu_lidar = *T;
  Estimator est(config.estimator);
  std::map<double, Eigen::Vector3d> poses;
  std::deque<LidarScan> waiting;
  std::optional<LidarScan> held;  // reversed_pair: the 100th scan, handed in after the 101st
  auto process = [&](const LidarScan& s) {
    const ScanReport r = est.ingest(s);
    const StateQuery q = est.query(s.t_end);
    if (q.ok() && r.points_kept > 0) poses[s.t_end] = q.x.p;
    if (held && s.t_end > held->t_end) {
      const LidarScan older = *held;
      held.reset();
      est.ingest(older);
    }
  };
  io::SensorEvent ev;
  int scans = 0;
  while (source->next(ev)) {
    if (ev.kind == io::SensorEvent::Kind::kLidar) {
      if (reversed_pair && ++scans == 100) {
        held = ev.scan;
      } else {
        waiting.push_back(ev.scan);
      }
      continue;
    }
    est.ingest(ev.imu);
    while (!waiting.empty() && ev.imu.t >= waiting.front().t_end + delay) {
      process(waiting.front());
      waiting.pop_front();
    }
  }
  for (const auto& s : waiting) process(s);
  if (counts) *counts = est.counters();
  return poses;
}

TEST(LateScans, AppliedAtTheirOwnTimeEqualOnTimeProcessing) {
  ASSERT_TRUE(std::filesystem::exists(kData + "/recording.mcap")) << "fixture missing: " << kData;
  const auto on_time = replay(0.0);
  for (double delay : {0.05, 0.2}) {
    const auto late = replay(delay);
    ASSERT_EQ(late.size(), on_time.size()) << "delay " << delay;
    double worst = 0.0;
    for (const auto& [t, p] : on_time) worst = std::max(worst, (late.at(t) - p).norm());
    // Same arithmetic in another order of arrival: equal to rounding.
    EXPECT_LT(worst, 1e-9) << "delay " << delay << " s";
  }
}

TEST(LateScans, AScanOlderThanOneProcessedIsRefusedAndCounted) {
  std::map<std::string, std::uint64_t> counts;
  const auto poses = replay(0.0, &counts, true);
  EXPECT_EQ(counts["scan_out_of_order"], 1u);
  EXPECT_GT(poses.size(), 500u);  // and the run goes on
}

}  // namespace
}  // namespace fuse
