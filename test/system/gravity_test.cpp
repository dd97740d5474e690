// Gravity in the map frame (estimator.estimate_gravity). Static initialisation cannot tell a
// horizontal accelerometer bias b from a tilt: it levels the first pose so that the mean specific
// force points up, which tilts the map frame by about |b_horizontal| / g. The map built from the
// first scans fixes that frame, so the true gravity direction in it is tilted too, and only turns
// (which rotate the bias relative to the world) separate the two. This test knows the truth: the
// simulator's first pose, so the true gravity in the estimator's map frame is
// g_W = R_W_est(t1) · R_W_true(t1)ᵀ · (0, 0, −g) at the first scan t1, the pose the map was built
// from. Over the corridor loop the estimate must come much closer to it than the levelled
// initial direction, which is where a fixed gravity stays.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>

#include "fuse/estimation/estimator.hpp"
#include "fuse/eval/association.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/io/sensor_source.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

const std::string kLoop = std::string(FUSE_TEST_DATA) + "/corridor_loop";
const std::string kShort = std::string(FUSE_TEST_DATA) + "/corridor60";  // same seed, first 60 s
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// The true rotation at time t: the ground-truth sample nearest to it (truth is at the IMU rate),
/// matched as the metrics match every estimate.
Eigen::Matrix3d true_rotation(const eval::Trajectory& truth, double t) {
  StampedPose at;
  at.t = t;
  return eval::associate_by_time(truth, {at}).reference.front().q.toRotationMatrix();
}

struct GravityOutcome {
  Eigen::Vector3d g_initial, g_final, g_true;
};

GravityOutcome run(const std::string& data, const std::vector<std::string>& overrides) {
  RunnerConfig config = load_runner_config(kConfig, overrides);
  auto source = io::open_sensor_source(data + "/recording.mcap");
  if (auto T = source->T_imu_lidar()) config.estimator.T_imu_lidar = *T;
  Estimator est(config.estimator);
  const eval::Trajectory truth = eval::read_tum(data + "/groundtruth.tum");
  GravityOutcome out;
  std::optional<double> first_scan;
  double last_scan = 0.0;
  io::SensorEvent ev;
  while (source->next(ev)) {
    if (ev.kind != io::SensorEvent::Kind::kLidar) {
      est.ingest(ev.imu);
      continue;
    }
    if (!first_scan) {
      const StateQuery q = est.query(ev.scan.t_end);  // the prior the first scan is mapped with
      if (q.ok()) {
        first_scan = ev.scan.t_end;
        out.g_initial = q.x.g;
        const Eigen::Matrix3d R_west_wtrue = q.x.R * true_rotation(truth, ev.scan.t_end).transpose();
        out.g_true = R_west_wtrue * Eigen::Vector3d(0, 0, -config.estimator.gravity_magnitude);
      }
    }
    est.ingest(ev.scan);
    last_scan = ev.scan.t_end;
  }
  out.g_final = est.query(last_scan).x.g;
  return out;
}

TEST(Gravity, TheMapFramesGravityIsEstimatedOverTheLoop) {
  ASSERT_TRUE(std::filesystem::exists(kLoop + "/recording.mcap")) << "fixture missing: " << kLoop;
  const GravityOutcome o = run(kLoop, {});
  const double initial_error = angle_between(o.g_initial, o.g_true);
  const double final_error = angle_between(o.g_final, o.g_true);
  RecordProperty("initial_error_mrad", std::to_string(1e3 * initial_error));
  RecordProperty("final_error_mrad", std::to_string(1e3 * final_error));
  // Seed 1's horizontal accelerometer bias (0.098 m/s²) tilts the levelled frame by ~10 mrad.
  ASSERT_GT(initial_error, 5e-3) << "the fixture no longer has a bias that tilts the initial frame";
  // Measured 2026-11-25: 10.1 -> 2.3 mrad. Half guards the behaviour.
  EXPECT_LT(final_error, 0.5 * initial_error)
      << "initial " << 1e3 * initial_error << " mrad, final " << 1e3 * final_error << " mrad";
}

// Negative control (on the loop's first minute): with gravity fixed, the direction never leaves
// the levelled initial one, ~10 mrad from the truth.
TEST(Gravity, FixedGravityKeepsTheLevelledDirection) {
  ASSERT_TRUE(std::filesystem::exists(kShort + "/recording.mcap")) << "fixture missing: " << kShort;
  const GravityOutcome o = run(kShort, {"estimator.estimate_gravity=false"});
  EXPECT_LT(angle_between(o.g_final, o.g_initial), 1e-12);
  EXPECT_GT(angle_between(o.g_final, o.g_true), 5e-3);
}

}  // namespace
}  // namespace fuse
