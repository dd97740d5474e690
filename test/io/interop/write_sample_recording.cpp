// Writes a short synthetic recording with RecordingWriter for the interoperability test
// (used when the fuse-sim tool is not part of the build).
// Usage: write_sample_recording OUT.mcap [zstd|lz4|none]
#include <cmath>
#include <cstdio>
#include <string>

#include "fuse/io/recording.hpp"

namespace {

constexpr double kImuRate = 200.0, kScanRate = 10.0, kDuration = 2.0;
constexpr int kPointsPerScan = 2000;
constexpr double kGravity = 9.81;

fuse::LidarScan make_scan(double t_start, double t_end, std::uint64_t sequence) {
  fuse::LidarScan scan;
  scan.t_start = t_start;
  scan.t_end = t_end;
  scan.sequence = sequence;
  for (int i = 0; i < kPointsPerScan; ++i) {
    const double a = 2.0 * M_PI * i / kPointsPerScan;
    scan.points.push_back({static_cast<float>(5.0 * std::cos(a)), static_cast<float>(5.0 * std::sin(a)), 0.5f, 10.f,
                           static_cast<float>((t_end - t_start) * i / kPointsPerScan), static_cast<std::uint16_t>(i % 4)});
  }
  return scan;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: %s OUT.mcap [zstd|lz4|none]\n", argv[0]);
    return 2;
  }
  fuse::io::RecordingWriterConfig config;
  const std::string compression = argc == 3 ? argv[2] : "zstd";
  if (compression == "lz4") {
    config.compression = fuse::io::Compression::kLz4;
  } else if (compression == "none") {
    config.compression = fuse::io::Compression::kNone;
  } else if (compression != "zstd") {
    std::fprintf(stderr, "unknown compression '%s'\n", compression.c_str());
    return 2;
  }
  config.chunk_size_bytes = 64 * 1024;  // several chunks
  fuse::io::RecordingWriter writer(argv[1], config);
  Eigen::Isometry3d T_imu_lidar = Eigen::Isometry3d::Identity();
  T_imu_lidar.translation() = Eigen::Vector3d(-0.011, -0.02329, 0.04412);
  writer.set_calibration(T_imu_lidar);
  const double t0 = 100.0;
  const int imu_per_scan = static_cast<int>(kImuRate / kScanRate);
  for (int i = 0; i <= static_cast<int>(kDuration * kImuRate); ++i) {
    fuse::ImuSample imu;
    imu.t = t0 + i / kImuRate;
    imu.gyro = Eigen::Vector3d(0.01, -0.02, 0.1 * std::sin(imu.t));
    imu.accel = Eigen::Vector3d(0.05, 0.0, kGravity);
    imu.sequence = static_cast<std::uint64_t>(i);
    writer.write(imu);
    if (i > 0 && i % imu_per_scan == 0) {
      writer.write(make_scan(imu.t - 1.0 / kScanRate, imu.t, static_cast<std::uint64_t>(i / imu_per_scan - 1)));
    }
  }
  writer.close();
  std::printf("wrote %s (%s)\n", argv[1], compression.c_str());
  return 0;
}
