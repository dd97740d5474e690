// fuse-import: converts a ROS 1 bag or a rosbag2 bag with sensor_msgs/Imu and
// sensor_msgs/PointCloud2 or Livox CustomMsg into the project's recording format (issue 5 item 5),
// so that fuse-run / fuse-launch can run public LiDAR-inertial datasets. Command line: the
// convention of every binary (fuse/cli/cli.hpp; --help, --version, usage errors exit 2).
#include <chrono>
#include <cmath>
#include <exception>
#include <iostream>
#include <optional>
#include <string>

#include "arguments.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/io/sensor_source.hpp"
#include "importer.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 1;
constexpr int kExitBadArguments = 2;

void print_topics(const fuse::rosbag::BagReader& bag, const fuse::import::TopicChoice& c,
                  const fuse::import::ImportSummary& s) {
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
}

/// The last lines: what this run did (read the whole bag or stopped at damage, what it wrote where,
/// in how long).
void print_outcome(const fuse::import::Arguments& args, const fuse::import::ImportSummary& s, double wall_s) {
  const std::uint64_t read = s.imu_messages + s.lidar_messages;
  const double rate = wall_s > 0.0 ? static_cast<double>(read) / wall_s : 0.0;
  if (args.T_imu_lidar) std::cout << "calibration: T_imu_lidar of --extrinsic stored in the recording\n";
  std::cout << "written: " << args.out << "\n"
            << (s.error.empty() ? "done: read the whole bag: " : "stopped at damage in the bag: read ")
            << fmt::format("{} IMU and LiDAR messages in {:.1f} s ({:.0f} messages/s); wrote {} IMU samples and {} scans\n",
                           read, wall_s, rate, s.imu_written, s.scans_written);
}

/// A 1 g mean in m/s^2 units (or ~9.8 g) points to the wrong --imu-accel-unit.
void warn_about_accel_unit(const fuse::import::ImportSummary& s) {
  if (s.imu_written == 0) return;
  if (std::abs(s.imu_mean_accel_norm - 1.0) < 0.3) {
    fuse::logger("import")->warn("the mean acceleration is {:.2f} m/s^2: the driver writes g? (--imu-accel-unit g)",
                                 s.imu_mean_accel_norm);
  }
  if (std::abs(s.imu_mean_accel_norm - 9.80665 * 9.80665) < 30.0) {
    fuse::logger("import")->warn("the mean acceleration is {:.1f} m/s^2: the driver writes m/s^2 (--imu-accel-unit mps2)?",
                                 s.imu_mean_accel_norm);
  }
}

/// Converts, prints the summary and returns the exit code; throws what the bag's opening throws.
int import(const fuse::import::Arguments& args) {
  const auto start = std::chrono::steady_clock::now();
  auto bag = fuse::rosbag::open_bag(args.input);
  const fuse::import::TopicChoice topics = fuse::import::choose_topics(*bag, args.import);
  fuse::io::RecordingWriter writer(args.out);
  if (args.T_imu_lidar) writer.set_calibration(*args.T_imu_lidar);
  const fuse::import::ImportSummary s = fuse::import::import_bag(*bag, topics, args.import, writer);
  writer.close();
  print_topics(*bag, topics, s);
  print_outcome(args, s, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  warn_about_accel_unit(s);
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
}

}  // namespace

int main(int argc, char** argv) {
  fuse::import::Arguments args;
  if (const std::optional<int> code = fuse::import::parse_arguments(argc, argv, args)) return *code;
  try {
    return import(args);
  } catch (const fuse::import::TopicError& e) {
    std::cerr << "fuse-import: " << e.what() << "\n";
    return kExitBadArguments;
  } catch (const std::exception& e) {  // fuse::io::InputError and any other failure
    std::cerr << "fuse-import: " << e.what() << "\n";
    return kExitBadInput;
  }
}
