// Ouster packets in a ROS 1 bag (ouster-sdk's test bag, ../shared/data/recordings/
// ouster_512x10_raw.bag: ouster_ros PacketMsg on /os_node0/lidar_packets and imu_packets, the
// metadata as a std_msgs/String on /os_node0/metadata): the packets decode with the bag's own
// metadata into full 512-column frames (points + empty returns = columns x beams, times spanning
// the frame) and 100 Hz IMU samples at about 1 g; wrong metadata for it is a clear error.
#include <gtest/gtest.h>

#include <filesystem>

#include "ouster_bag_source.hpp"

namespace fuse::service {
namespace {

const std::string kBag = std::string(FUSE_SHARED_DATA) + "/recordings/ouster_512x10_raw.bag";

#define REQUIRE_BAG()                                                                          \
  if (!std::filesystem::exists(kBag)) {                                                        \
    GTEST_SKIP() << "shared test data not found at " << kBag << " (FUSE_SHARED_DATA)";          \
  }

TEST(OusterBagSource, PacketsDecodeWithTheBagsMetadata) {
  REQUIRE_BAG();
  ASSERT_TRUE(OusterBagSource::holds_ouster_packets(kBag));
  OusterBagSource source(kBag, "");
  const auto& meta = source.metadata();
  EXPECT_EQ(meta.columns_per_frame, 512);
  std::vector<LidarScan> scans;
  std::vector<ImuSample> imu;
  io::SensorEvent ev;
  while (source.next(ev)) {
    if (ev.kind == io::SensorEvent::Kind::kLidar) {
      scans.push_back(ev.scan);
    } else {
      imu.push_back(ev.imu);
    }
  }
  ASSERT_GE(scans.size(), 1u);
  const auto& rejected = source.stats().rejected;
  const std::uint64_t empty =
      rejected.count(io::ouster::reject::kEmptyReturns) ? rejected.at(io::ouster::reject::kEmptyReturns) : 0;
  std::size_t points = 0;
  for (const auto& s : scans) {
    points += s.points.size();
    EXPECT_NEAR(s.t_end - s.t_start, 0.1 * (meta.window_columns() - 1) / 512.0, 0.002);
  }
  EXPECT_EQ(points + empty, scans.size() * static_cast<std::size_t>(meta.window_columns() * meta.pixels_per_column));
  ASSERT_GE(imu.size(), 2u);
  double g = 0.0;
  for (const auto& s : imu) g += s.accel.norm();
  EXPECT_NEAR(g / static_cast<double>(imu.size()), 9.81, 0.5);
  EXPECT_NEAR(static_cast<double>(imu.size() - 1) / (imu.back().t - imu.front().t), 100.0, 5.0);
  std::cout << scans.size() << " scans (" << points << " points), " << imu.size() << " IMU samples, profile "
            << io::ouster::profile_name(meta.lidar_profile) << "\n";
}

TEST(OusterBagSource, WrongMetadataForTheBagIsAClearError) {
  REQUIRE_BAG();
  const std::string other = std::string(FUSE_SHARED_DATA) + "/ouster/OS-2-128-U1_v2.3.0_1024x10.json";
  try {
    OusterBagSource source(kBag, other);
    io::SensorEvent ev;
    while (source.next(ev)) {
    }
    FAIL() << "decoded with another sensor's metadata";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("metadata's profile"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fuse::service
