// A ROS 2 LiDAR driver stand-in for the ROS 2 input test: reads a recording and publishes it, in
// real time, as a ROS 2 driver does: sensor_msgs/Imu and sensor_msgs/PointCloud2 (x, y, z,
// intensity float32, per-point time "t" uint32 ns after the header stamp as ouster_ros writes it,
// ring uint16) or livox_ros_driver2/CustomMsg, on rt/ topics with ROS 2 type names, reliable.
// It waits until a reader of both topics is matched, publishes, waits for acknowledgements, exits 0.
//   ros2_sensor_publisher DOMAIN RECORDING IMU_TOPIC LIDAR_TOPIC pointcloud2|livox [RATE]
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <algorithm>
#include <cstring>
#include <optional>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>

#include "fuse/io/sensor_source.hpp"
#include "fuse/transport/ros2.hpp"
#include "fuse/transport/transport.hpp"

namespace {

using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::FastBuffer;
using fuse::transport::Bytes;

Bytes serialised(std::size_t size, const std::function<void(Cdr&)>& body) {
  Bytes out(size + 1024);
  FastBuffer buffer(reinterpret_cast<char*>(out.data()), out.size());
  Cdr cdr(buffer, Cdr::LITTLE_ENDIANNESS, Cdr::DDS_CDR);
  cdr.serialize_encapsulation();
  body(cdr);
  out.resize(cdr.getSerializedDataLength());
  return out;
}

void header(Cdr& cdr, double t, const std::string& frame) {
  const auto s = fuse::transport::ros2::stamp_of(t);
  cdr << s.sec << s.nanosec << frame;
}

Bytes imu_msg(const fuse::ImuSample& imu) {
  return serialised(512, [&](Cdr& cdr) {
    header(cdr, imu.t, "imu");
    cdr << 0.0 << 0.0 << 0.0 << 1.0;                          // orientation (unknown)
    cdr << -1.0;                                              // orientation_covariance[0] = -1: not given
    for (int i = 1; i < 9; ++i) cdr << 0.0;
    cdr << imu.gyro.x() << imu.gyro.y() << imu.gyro.z();
    for (int i = 0; i < 9; ++i) cdr << 0.0;
    cdr << imu.accel.x() << imu.accel.y() << imu.accel.z();
    for (int i = 0; i < 9; ++i) cdr << 0.0;
  });
}

Bytes cloud_msg(const fuse::LidarScan& scan) {
  constexpr std::uint32_t kStep = 24;
  const auto n = static_cast<std::uint32_t>(scan.points.size());
  std::vector<std::uint8_t> data(static_cast<std::size_t>(n) * kStep, 0);
  for (std::uint32_t i = 0; i < n; ++i) {
    const fuse::LidarPoint& p = scan.points[i];
    const auto t_ns = static_cast<std::uint32_t>(std::llround(static_cast<double>(p.t_rel) * 1e9));
    std::uint8_t* d = data.data() + static_cast<std::size_t>(i) * kStep;
    std::memcpy(d, &p.x, 4);
    std::memcpy(d + 4, &p.y, 4);
    std::memcpy(d + 8, &p.z, 4);
    std::memcpy(d + 12, &p.intensity, 4);
    std::memcpy(d + 16, &t_ns, 4);
    std::memcpy(d + 20, &p.ring, 2);
  }
  return serialised(data.size() + 512, [&](Cdr& cdr) {
    header(cdr, scan.t_start, "lidar");
    cdr << std::uint32_t{1} << n;
    const struct { const char* name; std::uint32_t offset; std::uint8_t type; } fields[] = {
        {"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}, {"t", 16, 6}, {"ring", 20, 4}};
    cdr << std::uint32_t{6};
    for (const auto& f : fields) cdr << std::string(f.name) << f.offset << f.type << std::uint32_t{1};
    cdr << false << kStep << kStep * n << static_cast<std::uint32_t>(data.size());
    if (!data.empty()) cdr.serializeArray(data.data(), data.size());
    cdr << true;
  });
}

Bytes livox_msg(const fuse::LidarScan& scan) {
  const auto n = static_cast<std::uint32_t>(scan.points.size());
  const auto timebase = static_cast<std::uint64_t>(std::llround(scan.t_start * 1e9));
  return serialised(static_cast<std::size_t>(n) * 24 + 512, [&](Cdr& cdr) {
    header(cdr, scan.t_start, "lidar");
    cdr << timebase << n << std::uint8_t{0};
    const std::uint8_t rsvd[3] = {0, 0, 0};
    cdr.serializeArray(rsvd, 3);
    cdr << n;
    for (const fuse::LidarPoint& p : scan.points) {
      cdr << static_cast<std::uint32_t>(std::llround(static_cast<double>(p.t_rel) * 1e9)) << p.x << p.y << p.z;
      cdr << static_cast<std::uint8_t>(std::min(255.f, std::max(0.f, p.intensity))) << std::uint8_t{0}
          << static_cast<std::uint8_t>(p.ring);
    }
  });
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "usage: ros2_sensor_publisher DOMAIN RECORDING IMU_TOPIC LIDAR_TOPIC pointcloud2|livox [RATE]\n");
    return 2;
  }
  namespace ros2 = fuse::transport::ros2;
  const std::string type = argv[5];
  const double rate = argc > 6 ? std::atof(argv[6]) : 1.0;
  fuse::transport::TransportConfig tc;
  tc.domain_id = std::atoi(argv[1]);
  auto participant = fuse::transport::make_participant(tc, "ros2-driver");
  fuse::transport::TopicQos qos = ros2::default_qos();
  qos.depth = 1000;
  auto imu = participant->create_writer(ros2::dds_topic(argv[3]),
                                        ros2::type_support("sensor_msgs::msg::dds_::Imu_", 4096), qos);
  auto lidar = participant->create_writer(
      ros2::dds_topic(argv[4]),
      ros2::type_support(type == "livox" ? "livox_ros_driver2::msg::dds_::CustomMsg_" : ros2::kPointCloud2Type,
                         std::size_t{64} << 20),
      qos);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (imu->matched_readers() == 0 || lidar->matched_readers() == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "no reader of %s and %s within 60 s\n", argv[3], argv[4]);
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  auto source = fuse::io::open_sensor_source(argv[2]);
  fuse::io::SensorEvent ev;
  std::optional<double> t0;
  const auto wall0 = std::chrono::steady_clock::now();
  std::size_t imus = 0, scans = 0;
  while (source->next(ev)) {
    const double t = ev.arrival_time();
    if (!t0) t0 = t;
    std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                              std::chrono::duration<double>((t - *t0) / rate)));
    if (ev.kind == fuse::io::SensorEvent::Kind::kImu) {
      imu->write(imu_msg(ev.imu));
      ++imus;
    } else {
      lidar->write(type == "livox" ? livox_msg(ev.scan) : cloud_msg(ev.scan));
      ++scans;
    }
  }
  imu->wait_for_acknowledgments(std::chrono::seconds(10));
  lidar->wait_for_acknowledgments(std::chrono::seconds(10));
  std::printf("published %zu IMU samples and %zu scans\n", imus, scans);
  return 0;
}
