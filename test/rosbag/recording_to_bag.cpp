// Test tool: writes a recording (MCAP or sequence directory) as a ROS 1 bag the way a LiDAR
// driver would publish it: sensor_msgs/Imu on /imu and sensor_msgs/PointCloud2 on /points with
// x, y, z, intensity (float32), t (uint32 ns after the header stamp, the scan start) and ring
// (uint16). Used to check that fuse-import + fuse-run reproduce a run on the original recording.
// Usage: recording_to_bag INPUT OUT.bag   (also OUT.bag.extrinsic when the input has a calibration)
#include <cmath>
#include <cstdio>
#include <iostream>

#include "fuse/io/sensor_source.hpp"
#include "message_encoder.hpp"
#include "ros1_bag_writer.hpp"

using fuse::rosbag::Serialization;
using fuse::rosbag::test::Encoder;

namespace {

std::uint64_t to_ns(double t) { return static_cast<std::uint64_t>(std::llround(t * 1e9)); }

std::vector<std::uint8_t> imu_message(const fuse::ImuSample& s) {
  Encoder e(Serialization::kRos1);
  e.header(to_ns(s.t), "imu");
  for (double v : {0.0, 0.0, 0.0, 1.0}) e.put(v);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  for (int k = 0; k < 3; ++k) e.put(s.gyro[k]);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  for (int k = 0; k < 3; ++k) e.put(s.accel[k]);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  return e.buf;
}

std::vector<std::uint8_t> cloud_message(const fuse::LidarScan& scan, std::uint64_t stamp) {
  Encoder e(Serialization::kRos1);
  e.header(stamp, "lidar");
  e.put<std::uint32_t>(1);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(scan.points.size()));
  const std::vector<std::tuple<const char*, std::uint32_t, std::uint8_t>> fields = {
      {"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}, {"t", 16, 6}, {"ring", 20, 4}};
  e.put<std::uint32_t>(static_cast<std::uint32_t>(fields.size()));
  for (const auto& [name, offset, type] : fields) {
    e.str(name);
    e.put<std::uint32_t>(offset);
    e.put<std::uint8_t>(type);
    e.put<std::uint32_t>(1);
  }
  e.put<std::uint8_t>(0);
  const std::uint32_t step = 24;
  e.put<std::uint32_t>(step);
  e.put<std::uint32_t>(step * static_cast<std::uint32_t>(scan.points.size()));
  e.put<std::uint32_t>(step * static_cast<std::uint32_t>(scan.points.size()));
  const double start = static_cast<double>(stamp) * 1e-9;
  for (const auto& p : scan.points) {
    e.put<float>(p.x);
    e.put<float>(p.y);
    e.put<float>(p.z);
    e.put<float>(p.intensity);
    const double t = scan.t_start + static_cast<double>(p.t_rel) - start;
    e.put<std::uint32_t>(static_cast<std::uint32_t>(std::llround(std::max(0.0, t) * 1e9)));
    e.put<std::uint16_t>(p.ring);
    e.put<std::uint16_t>(0);
  }
  e.put<std::uint8_t>(1);
  return e.buf;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: recording_to_bag INPUT OUT.bag\n";
    return 2;
  }
  try {
    auto source = fuse::io::open_sensor_source(argv[1]);
    const std::string md5(32, '0');
    std::vector<fuse::rosbag::test::WriterConnection> conns = {{0, "/imu", "sensor_msgs/Imu", md5, ""},
                                                              {1, "/points", "sensor_msgs/PointCloud2", md5, ""}};
    std::vector<fuse::rosbag::test::WriterMessage> msgs;
    fuse::io::SensorEvent ev;
    while (source->next(ev)) {
      if (ev.kind == fuse::io::SensorEvent::Kind::kImu) {
        msgs.push_back({0, to_ns(ev.imu.t), imu_message(ev.imu)});
      } else {
        const std::uint64_t stamp = to_ns(ev.scan.t_start);
        msgs.push_back({1, to_ns(ev.scan.t_end), cloud_message(ev.scan, stamp)});
      }
    }
    if (const auto T = source->T_imu_lidar()) {
      // The extrinsic as fuse-import's --extrinsic value, beside the bag.
      const Eigen::Quaterniond q(T->linear());
      std::FILE* f = std::fopen((std::string(argv[2]) + ".extrinsic").c_str(), "w");
      if (f == nullptr) throw std::runtime_error("cannot write the extrinsic file");
      std::fprintf(f, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", T->translation().x(), T->translation().y(),
                   T->translation().z(), q.x(), q.y(), q.z(), q.w());
      std::fclose(f);
    }
    fuse::rosbag::test::write_file(argv[2], fuse::rosbag::test::write_bag(conns, msgs, "lz4", 200));
    std::cout << msgs.size() << " messages written to " << argv[2] << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "recording_to_bag: " << e.what() << "\n";
    return 1;
  }
}
