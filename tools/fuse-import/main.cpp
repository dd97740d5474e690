// fuse-import: converts a ROS 1 bag or a rosbag2 bag with sensor_msgs/Imu and
// sensor_msgs/PointCloud2 or Livox CustomMsg into the project's recording format (issue 5 item 5),
// so that fuse-run / fuse-launch can run public LiDAR-inertial datasets.
#include <cmath>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "arguments.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/io/sensor_source.hpp"
#include "importer.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 1;
constexpr int kExitBadArguments = 2;

void print_summary(const fuse::rosbag::BagReader& bag, const fuse::import::TopicChoice& c,
                   const fuse::import::ImportSummary& s, const std::string& out) {
  const auto& imu = bag.topics()[c.imu];
  const auto& lidar = bag.topics()[c.lidar];
  std::cout << "input:  " << bag.describe() << "\n"
            << "imu:    " << imu.name << " [" << imu.type << "] " << s.imu_messages << " messages -> "
            << s.imu_written << " samples\n"
            << "lidar:  " << lidar.name << " [" << lidar.type << "] " << s.lidar_messages << " messages -> "
            << s.scans_written << " scans, " << s.points.kept << " points (dropped: " << s.points.nan_points
            << " NaN/inf, " << s.points.zero_points << " at the origin)\n";
  if (s.other_topic_messages > 0) std::cout << "other topics: " << s.other_topic_messages << " messages not imported\n";
  for (const auto& [reason, n] : s.skipped) std::cout << "skipped: " << reason << ": " << n << "\n";
  std::cout << "mean |accel| " << s.imu_mean_accel_norm << " m/s^2\n";
  std::cout << "written: " << out << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  fuse::import::Arguments args;
  try {
    args = fuse::import::parse_arguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::cerr << "fuse-import: " << e.what() << "\n" << fuse::import::usage();
    return kExitBadArguments;
  }
  if (args.help) {
    std::cout << fuse::import::usage();
    return kExitOk;
  }
  try {
    auto bag = fuse::rosbag::open_bag(args.input);
    const fuse::import::TopicChoice topics = fuse::import::choose_topics(*bag, args.import);
    fuse::io::RecordingWriter writer(args.out);
    if (args.T_imu_lidar) writer.set_calibration(*args.T_imu_lidar);
    const fuse::import::ImportSummary s = fuse::import::import_bag(*bag, topics, args.import, writer);
    writer.close();
    print_summary(*bag, topics, s, args.out);
    // A 1 g mean in m/s^2 units (or ~9.8 g) points to the wrong --imu-accel-unit.
    if (s.imu_written > 0 && std::abs(s.imu_mean_accel_norm - 1.0) < 0.3) {
      fuse::logger("import")->warn("the mean acceleration is {:.2f} m/s^2: the driver writes g? (--imu-accel-unit g)",
                                   s.imu_mean_accel_norm);
    }
    if (s.imu_written > 0 && std::abs(s.imu_mean_accel_norm - 9.80665 * 9.80665) < 30.0) {
      fuse::logger("import")->warn("the mean acceleration is {:.1f} m/s^2: the driver writes m/s^2 (--imu-accel-unit mps2)?",
                                   s.imu_mean_accel_norm);
    }
    if (!s.error.empty()) {
      std::cerr << "fuse-import: " << s.error << "\n(the messages converted before it are in " << args.out << ")\n";
      return kExitBadInput;
    }
    if (s.imu_written == 0 || s.scans_written == 0) {
      std::cerr << "fuse-import: nothing usable converted (" << s.imu_written << " IMU samples, " << s.scans_written
                << " scans)\n";
      return kExitBadInput;
    }
    return kExitOk;
  } catch (const fuse::import::TopicError& e) {
    std::cerr << "fuse-import: " << e.what() << "\n";
    return kExitBadArguments;
  } catch (const fuse::io::InputError& e) {
    std::cerr << "fuse-import: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "fuse-import: " << e.what() << "\n";
    return kExitBadInput;
  }
}
