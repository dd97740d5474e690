// Command-line parsing of fuse-import: every argument is checked before the bag is opened.
#include "arguments.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "fuse/cli/cli.hpp"
#include "fuse/rosbag/scan_conversion.hpp"

namespace fuse::import {
namespace {

/// A value that does not check; parse_arguments prints it as a usage error (exit code 2).
class BadValue : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Standard gravity (m/s^2 per g), for drivers that write the acceleration in g.
constexpr double kStandardGravity = 9.80665;

/// "tx,ty,tz,qx,qy,qz,qw" -> the 7 numbers, each finite.
std::vector<double> parse_numbers(const std::string& text) {
  std::stringstream ss(text);
  std::vector<double> v;
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw BadValue("--extrinsic: '" + item + "' is not a number");
    }
  }
  if (v.size() != 7) throw BadValue("--extrinsic needs 7 comma-separated numbers tx,ty,tz,qx,qy,qz,qw");
  for (double x : v) {
    if (!std::isfinite(x)) throw BadValue("--extrinsic: values must be finite");
  }
  return v;
}

/// "tx,ty,tz,qx,qy,qz,qw" -> T_imu_lidar (the quaternion must have unit norm within 1e-3).
Eigen::Isometry3d parse_extrinsic(const std::string& text) {
  const std::vector<double> v = parse_numbers(text);
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > 1e-3) throw BadValue("--extrinsic: the quaternion qx,qy,qz,qw is not of unit norm");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T;
}

/// The acceleration unit's factor to m/s^2.
double accel_scale_of(const std::string& unit) {
  if (unit == "g") return kStandardGravity;
  if (unit == "mps2") return 1.0;
  throw BadValue("--imu-accel-unit: '" + unit + "' is not g or mps2");
}

/// The options' texts that are checked after parsing.
struct Given {
  std::string accel_unit = "mps2", extrinsic;
};

void add_options(CLI::App& app, Arguments& a, Given& g) {
  app.add_option("--input", a.input,
                 "a ROS 1 bag (.bag, v2.0: uncompressed, bz2 or lz4 chunks), a rosbag2 directory (metadata.yaml "
                 "with sqlite3 or mcap storage), or one .db3/.mcap file")
      ->type_name("BAG_OR_DIR")
      ->required();
  app.add_option("--out", a.out, "the recording to write (MCAP, channels imu and lidar/scan)")
      ->type_name("RECORDING.mcap")
      ->required();
  app.add_option("--imu-topic", a.import.imu_topic, "sensor_msgs/Imu topic (default: the only one in the bag)")
      ->type_name("T");
  app.add_option("--lidar-topic", a.import.lidar_topic,
                 "sensor_msgs/PointCloud2 or livox_ros_driver[2]/CustomMsg topic (default: the only one)")
      ->type_name("T");
  app.add_option("--time-field", a.import.time_field,
                 "per-point time field of PointCloud2 (default: the first present of t [ns, Ouster], time [s "
                 "relative, Velodyne], timestamp [s absolute, Hesai], offset_time [ns, Livox])")
      ->type_name("t|time|timestamp|offset_time");
  app.add_option("--imu-accel-unit", g.accel_unit,
                 "mps2 (default) or g (e.g. the Livox built-in IMU of livox_ros_driver)")
      ->type_name("g|mps2");
  app.add_option("--extrinsic", g.extrinsic,
                 "T_imu_lidar (p_imu = R p_lidar + t), stored in the recording; fuse-run and fuse-launch then use "
                 "it instead of the config's estimator.extrinsic")
      ->type_name("tx,ty,tz,qx,qy,qz,qw");
}

/// The values CLI11 does not check: time field, acceleration unit, extrinsic.
void check_values(const CLI::App& app, const Given& g, Arguments& a) {
  if (app.count("--time-field") > 0 && !rosbag::known_time_field(a.import.time_field)) {
    throw BadValue("--time-field: '" + a.import.time_field + "' is not t, time, timestamp or offset_time");
  }
  a.import.accel_scale = accel_scale_of(g.accel_unit);
  if (app.count("--extrinsic") > 0) a.T_imu_lidar = parse_extrinsic(g.extrinsic);
}

}  // namespace

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  const auto app = cli::make_app(
      "fuse-import",
      "Converts a ROS 1 bag or a rosbag2 bag with sensor_msgs/Imu and sensor_msgs/PointCloud2 or Livox CustomMsg "
      "into a recording for fuse-run and fuse-launch. Prints a progress line every 5 s, then what was converted "
      "and what was skipped, by reason.",
      "Exit codes: 0 success, 1 unreadable or damaged input (what was converted before is kept), 2 bad arguments "
      "or topics that cannot be chosen.");
  Given g;
  add_options(*app, a, g);
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  try {
    check_values(*app, g, a);
  } catch (const BadValue& e) {
    return cli::usage_error(*app, e.what());
  }
  return std::nullopt;
}

}  // namespace fuse::import
