// Command-line parsing of fuse-import: every argument is checked before the bag is opened.
#include "arguments.hpp"

#include <cmath>
#include <sstream>

#include "fuse/rosbag/scan_conversion.hpp"

namespace fuse::import {
namespace {

const std::string& value_of(const std::vector<std::string>& args, std::size_t& i) {
  if (i + 1 >= args.size()) throw ArgumentError(args[i] + " needs a value");
  return args[++i];
}

/// Standard gravity (m/s^2 per g), for drivers that write the acceleration in g.
constexpr double kStandardGravity = 9.80665;

/// "tx,ty,tz,qx,qy,qz,qw" -> T_imu_lidar (the quaternion must have unit norm within 1e-3).
Eigen::Isometry3d parse_extrinsic(const std::string& text) {
  std::stringstream ss(text);
  std::vector<double> v;
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ArgumentError("--extrinsic: '" + item + "' is not a number");
    }
  }
  if (v.size() != 7) throw ArgumentError("--extrinsic needs 7 comma-separated numbers tx,ty,tz,qx,qy,qz,qw");
  for (double x : v) {
    if (!std::isfinite(x)) throw ArgumentError("--extrinsic: values must be finite");
  }
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > 1e-3) throw ArgumentError("--extrinsic: the quaternion qx,qy,qz,qw is not of unit norm");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T;
}

}  // namespace

std::string usage() {
  return "usage: fuse-import --input BAG_OR_DIR --out RECORDING.mcap [--imu-topic T] [--lidar-topic T]\n"
         "                   [--time-field t|time|timestamp|offset_time] [--imu-accel-unit g|mps2]\n"
         "                   [--extrinsic tx,ty,tz,qx,qy,qz,qw]\n"
         "  --input P          a ROS 1 bag (.bag, v2.0: uncompressed, bz2 or lz4 chunks), a rosbag2\n"
         "                     directory (metadata.yaml with sqlite3 or mcap storage), or one .db3/.mcap file\n"
         "  --out FILE         the recording to write (MCAP, channels imu and lidar/scan)\n"
         "  --imu-topic T      sensor_msgs/Imu topic (default: the only one in the bag)\n"
         "  --lidar-topic T    sensor_msgs/PointCloud2 or livox_ros_driver[2]/CustomMsg topic (default: the only one)\n"
         "  --time-field NAME  per-point time field of PointCloud2 (default: the first present of\n"
         "                     t [ns, Ouster], time [s relative, Velodyne], timestamp [s absolute, Hesai],\n"
         "                     offset_time [ns, Livox])\n"
         "  --imu-accel-unit U mps2 (default) or g (e.g. the Livox built-in IMU of livox_ros_driver)\n"
         "  --extrinsic T      T_imu_lidar (p_imu = R p_lidar + t), stored in the recording; fuse-run and\n"
         "                     fuse-launch then use it instead of the config's estimator.extrinsic\n"
         "Prints what was converted and what was skipped, by reason.\n"
         "Exit codes: 0 success, 1 unreadable or damaged input (what was converted before is kept),\n"
         "2 bad arguments or topics that cannot be chosen.\n";
}

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--input") {
      a.input = value_of(args, i);
    } else if (arg == "--out") {
      a.out = value_of(args, i);
    } else if (arg == "--imu-topic") {
      a.import.imu_topic = value_of(args, i);
    } else if (arg == "--lidar-topic") {
      a.import.lidar_topic = value_of(args, i);
    } else if (arg == "--time-field") {
      a.import.time_field = value_of(args, i);
      if (!rosbag::known_time_field(a.import.time_field)) {
        throw ArgumentError("--time-field: '" + a.import.time_field + "' is not t, time, timestamp or offset_time");
      }
    } else if (arg == "--imu-accel-unit") {
      const std::string& u = value_of(args, i);
      if (u == "g") {
        a.import.accel_scale = kStandardGravity;
      } else if (u == "mps2") {
        a.import.accel_scale = 1.0;
      } else {
        throw ArgumentError("--imu-accel-unit: '" + u + "' is not g or mps2");
      }
    } else if (arg == "--extrinsic") {
      a.T_imu_lidar = parse_extrinsic(value_of(args, i));
    } else {
      throw ArgumentError("unknown argument '" + arg + "'");
    }
  }
  if (a.help) return a;
  if (a.input.empty()) throw ArgumentError("--input is required");
  if (a.out.empty()) throw ArgumentError("--out is required");
  return a;
}

}  // namespace fuse::import
