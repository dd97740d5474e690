// The written files read back through fuse::io::open_sensor_source (MCAP and sequence directory):
// counts, order, calibration and the points of the first scan as simulated directly.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iomanip>
#include <filesystem>
#include <string>
#include <vector>
#include <unistd.h>

#include "fuse/io/sensor_source.hpp"
#include "fuse/sim/lidar_model.hpp"
#include "fuse/sim/scenario.hpp"

using namespace fuse::sim;
namespace fs = std::filesystem;

class SimRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(SimRoundTrip, ReadsBackThroughSensorSource) {
  const fs::path dir = fs::temp_directory_path() / ("fuse_sim_rt_" + GetParam() + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string cmd = std::string(FUSE_SIM_EXE) + " --scenario corridor --seed 4 --duration 0.5 --format " +
                          GetParam() + " --out " + dir.string() + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string path = GetParam() == "mcap" ? (dir / "recording.mcap").string() : dir.string();
  auto source = fuse::io::open_sensor_source(path);
  ASSERT_TRUE(source->T_imu_lidar().has_value());
  EXPECT_TRUE(source->T_imu_lidar()->isApprox(default_T_imu_lidar(), 1e-6));

  const Scenario sc = make_scenario("corridor", 4, 4);
  LidarSimulator direct(LidarConfig::mid360(), sc.world, *sc.trajectory, default_T_imu_lidar(), 4);
  const fuse::LidarScan first = direct.scan(0, kStartTime);

  fuse::io::SensorEvent e;
  std::size_t imu = 0, scans = 0;
  double last_arrival = -1.0;
  while (source->next(e)) {
    EXPECT_GE(e.arrival_time(), last_arrival);
    last_arrival = e.arrival_time();
    if (e.kind == fuse::io::SensorEvent::Kind::kImu) {
      EXPECT_NEAR(e.imu.t, kStartTime + imu * 0.005, 1e-6);
      ++imu;
      continue;
    }
    if (scans == 0) {
      EXPECT_NEAR(e.scan.t_start, kStartTime, 1e-6);
      ASSERT_EQ(e.scan.points.size(), first.points.size());
      for (std::size_t i = 0; i < first.points.size(); ++i) {
        ASSERT_EQ(e.scan.points[i].x, first.points[i].x);
        ASSERT_EQ(e.scan.points[i].t_rel, first.points[i].t_rel);
        ASSERT_EQ(e.scan.points[i].ring, first.points[i].ring);
      }
    }
    ++scans;
  }
  EXPECT_EQ(imu, 101u);
  EXPECT_EQ(scans, 5u);
  EXPECT_TRUE(source->stats().rejected.empty());
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Formats, SimRoundTrip, ::testing::Values("mcap", "seqdir"));

namespace {
struct Read {
  std::vector<fuse::ImuSample> imu;
  std::vector<fuse::LidarScan> scans;
  bool in_stamp_order = true;
};

Read simulate_and_read(const std::string& offset) {
  const fs::path dir = fs::temp_directory_path() / ("fuse_sim_offset_" + offset + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string cmd = std::string(FUSE_SIM_EXE) + " --scenario room --seed 2 --duration 1 --imu-time-offset " +
                          offset + " --out " + dir.string() + " >/dev/null 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  Read r;
  auto source = fuse::io::open_sensor_source((dir / "recording.mcap").string());
  fuse::io::SensorEvent e;
  double last = -1e300;
  while (source->next(e)) {
    const double t = e.kind == fuse::io::SensorEvent::Kind::kImu ? e.imu.t : e.scan.t_end;
    // To MCAP's log-time resolution (1 ns): a sample and a scan end on the same nanosecond tie.
    if (t < last - 1e-9 && r.in_stamp_order) {
      ADD_FAILURE() << "event at t=" << std::setprecision(17) << t << " after t=" << last << " ("
                    << (e.kind == fuse::io::SensorEvent::Kind::kImu ? "IMU" : "scan") << ")";
      r.in_stamp_order = false;
    }
    last = t;
    if (e.kind == fuse::io::SensorEvent::Kind::kImu) {
      r.imu.push_back(e.imu);
    } else {
      r.scans.push_back(e.scan);
    }
  }
  EXPECT_TRUE(source->stats().rejected.empty());
  fs::remove_all(dir);
  return r;
}
}  // namespace

// --imu-time-offset S: the same IMU measurements, each stamped S late (or early), the scans as
// without it, and the file still in stamp order (a replay sees what an unsynchronised pair sends).
TEST(SimImuTimeOffset, StampsTheImuLateAndKeepsTheScans) {
  const Read plain = simulate_and_read("0");
  for (const char* offset : {"0.02", "-0.05"}) {
    const double s = std::atof(offset);
    const Read shifted = simulate_and_read(offset);
    EXPECT_TRUE(shifted.in_stamp_order) << offset;
    ASSERT_EQ(shifted.imu.size(), plain.imu.size()) << offset;
    for (std::size_t i = 0; i < plain.imu.size(); ++i) {
      ASSERT_NEAR(shifted.imu[i].t, plain.imu[i].t + s, 1e-9) << offset << " sample " << i;
      ASSERT_EQ(shifted.imu[i].gyro, plain.imu[i].gyro);
      ASSERT_EQ(shifted.imu[i].accel, plain.imu[i].accel);
    }
    ASSERT_EQ(shifted.scans.size(), plain.scans.size()) << offset;
    for (std::size_t k = 0; k < plain.scans.size(); ++k) {
      EXPECT_EQ(shifted.scans[k].t_end, plain.scans[k].t_end);
      ASSERT_EQ(shifted.scans[k].points.size(), plain.scans[k].points.size());
    }
  }
}
