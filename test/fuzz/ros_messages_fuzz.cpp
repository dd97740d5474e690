// libFuzzer target for the ROS message decoders and their conversion (issue 5: malformed
// messages are counted errors, never a crash). The first byte chooses the message type and the
// wire format (ROS 1 / CDR), the second the time field convention; the rest is the message.
// A decoded cloud converts into a scan of finite points with 0 <= t_rel <= t_end - t_start, or
// raises fuse::io::InputError.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/scan_conversion.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"
#include "rosbag_fuzz_util.hpp"

namespace {

void check_scan(const fuse::LidarScan& scan) {
  using fuse::fuzz::require;
  if (scan.points.empty()) return;
  require(scan.t_end >= scan.t_start);
  const double span = scan.t_end - scan.t_start;
  // t_end - t_start is rounded at the absolute times' resolution (a few ulp of t_end).
  const double slack = 4.0 * std::numeric_limits<double>::epsilon() * std::abs(scan.t_end) + 1e-6;
  for (const auto& p : scan.points) {
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    require(p.t_rel >= 0.f && static_cast<double>(p.t_rel) <= span * 1.0001 + slack);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fuse::rosbag;
  fuse::fuzz::quiet();
  if (size < 2) return 0;
  const Serialization s = (data[0] & 1) ? Serialization::kCdr : Serialization::kRos1;
  static const char* kFields[] = {"", "t", "time", "timestamp", "offset_time"};
  const std::string field = kFields[data[1] % 5];
  const std::uint8_t* msg = data + 2;
  const std::size_t n = size - 2;
  try {
    switch ((data[0] >> 1) % 3) {
      case 0: {
        const fuse::ImuSample imu = imu_to_sample(decode_imu(msg, n, s, "fuzz"), 9.80665);
        fuse::fuzz::require(imu.t >= 0.0);
        break;
      }
      case 1: {
        PointCounts counts;
        const PointCloud2Msg cloud = decode_point_cloud2(msg, n, s, "fuzz");
        const fuse::LidarScan scan = cloud_to_scan(cloud, field, counts, "fuzz");
        fuse::fuzz::require(counts.kept == scan.points.size());
        check_scan(scan);
        break;
      }
      default: {
        PointCounts counts;
        const LivoxCustomMsg m = decode_livox_custom(msg, n, s, "fuzz");
        const fuse::LidarScan scan = livox_to_scan(m, counts);
        fuse::fuzz::require(counts.kept + counts.nan_points + counts.zero_points == m.points.size());
        check_scan(scan);
        break;
      }
    }
  } catch (const fuse::io::InputError& e) {
    fuse::fuzz::require(e.what()[0] != '\0');
  }
  return 0;
}
