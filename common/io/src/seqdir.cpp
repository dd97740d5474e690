#include "fuse/io/seqdir.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "fuse/io/seqdir_source.hpp"
#include "fuse/io/time_ns.hpp"

namespace fuse::io {
namespace {

namespace fs = std::filesystem;

/// Shortest text that reads back to the same double, with ".0" on integral values
/// (the calib.yaml style of the reference sample: [-0.011, -0.02329, 0.04412], [0.0, ..., 1.0]).
std::string shortest(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, res.ptr);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string list(std::initializer_list<double> values) {
  std::string s = "[";
  for (const double v : values) s += (s.size() > 1 ? ", " : "") + shortest(v);
  return s + "]";
}

void check(const std::ostream& out, const std::string& file) {
  if (!out) throw std::runtime_error("write to '" + file + "' failed");
}

}  // namespace

SeqdirWriter::SeqdirWriter(const std::string& dir, const Eigen::Isometry3d& T_imu_lidar) : dir_(dir) {
  fs::create_directories(fs::path(dir) / "raw");
  const Eigen::Vector3d t = T_imu_lidar.translation();
  const Eigen::Quaterniond q(T_imu_lidar.rotation());
  std::ofstream calib(dir + "/calib.yaml");
  calib << "# LiDAR pose in the IMU frame: p_imu = R * p_lidar + t  (rotation as a unit quaternion, x y z w)\n"
        << "T_imu_lidar:\n"
        << "  translation: " << list({t.x(), t.y(), t.z()}) << "\n"
        << "  rotation_xyzw: " << list({q.x(), q.y(), q.z(), q.w()}) << "\n";
  check(calib, dir + "/calib.yaml");
  scans_csv_.open(dir + "/scans.csv");
  imu_csv_.open(dir + "/imu.csv");
  scans_csv_ << "idx,t_start,t_end\n";
  imu_csv_ << "timestamp,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n";
  check(scans_csv_, dir + "/scans.csv");
  check(imu_csv_, dir + "/imu.csv");
}

void SeqdirWriter::write(const ImuSample& imu) {
  // Integer nanoseconds as the reference sample; readers take values below kNanosecondThreshold
  // as seconds, so early times (t < 10 s) are written in seconds with 9 decimals instead.
  // Then 9 significant digits per value, as the sample.
  const std::uint64_t ns = seconds_to_ns(imu.t);
  char stamp[32];
  if (static_cast<double>(ns) > kNanosecondThreshold) {
    std::snprintf(stamp, sizeof stamp, "%llu", static_cast<unsigned long long>(ns));
  } else {
    std::snprintf(stamp, sizeof stamp, "%.9f", imu.t);
  }
  char line[256];
  std::snprintf(line, sizeof line, "%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", stamp, imu.gyro.x(), imu.gyro.y(), imu.gyro.z(),
                imu.accel.x(), imu.accel.y(), imu.accel.z());
  imu_csv_ << line;
  check(imu_csv_, dir_ + "/imu.csv");
}

void SeqdirWriter::write(const LidarScan& scan) {
  char name[32];
  std::snprintf(name, sizeof name, "raw/%06zu.bin", scan_index_);
  const std::string path = dir_ + "/" + name;
  std::vector<float> raw;
  raw.reserve(scan.points.size() * 6);
  for (const auto& p : scan.points) raw.insert(raw.end(), {p.x, p.y, p.z, p.intensity, p.t_rel, static_cast<float>(p.ring)});
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(raw.data()), static_cast<std::streamsize>(raw.size() * sizeof(float)));
  check(out, path);
  char line[96];
  std::snprintf(line, sizeof line, "%zu,%.9f,%.9f\n", scan_index_, scan.t_start, scan.t_end);
  scans_csv_ << line;
  check(scans_csv_, dir_ + "/scans.csv");
  ++scan_index_;
}

void SeqdirWriter::write_groundtruth(const std::vector<StampedPose>& poses) {
  const std::string file = dir_ + "/gt_tum.txt";
  std::ofstream out(file);
  for (const auto& p : poses) {
    char line[256];
    std::snprintf(line, sizeof line, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", p.t, p.p.x(), p.p.y(), p.p.z(),
                  p.q.x(), p.q.y(), p.q.z(), p.q.w());
    out << line;
  }
  check(out, file);
}

void SeqdirWriter::close() {
  scans_csv_.close();
  imu_csv_.close();
  if (scans_csv_.fail() || imu_csv_.fail()) throw std::runtime_error("closing the CSV files in '" + dir_ + "' failed");
}

}  // namespace fuse::io
