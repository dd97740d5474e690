// Livox SDK2 packets built byte by byte from the protocol document (Livox LiDAR Communication
// Protocol – Mid-360, "Point Cloud & IMU Data Protocol"), independently of the decoder's own
// encoder: header fields at their documented offsets, little-endian, then the points.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace fuse::test::livox {

struct RawPoint {
  double x = 0, y = 0, z = 0;  ///< metres
  std::uint8_t reflectivity = 0, tag = 0;
};

inline void put_bytes(std::vector<std::uint8_t>& out, const void* p, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + n);
  std::memcpy(out.data() + at, p, n);
}
template <class T>
void put(std::vector<std::uint8_t>& out, T v) {
  put_bytes(out, &v, sizeof(T));
}

/// Header (36 bytes) + data. `length` 0 = the real size.
inline std::vector<std::uint8_t> packet(std::uint8_t data_type, std::uint16_t dot_num, std::uint16_t time_interval,
                                        std::uint64_t timestamp_ns, const std::vector<std::uint8_t>& data,
                                        std::uint8_t version = 0, std::uint16_t length = 0) {
  std::vector<std::uint8_t> out;
  put<std::uint8_t>(out, version);                                                  // 0 version
  put<std::uint16_t>(out, length ? length : static_cast<std::uint16_t>(36 + data.size()));  // 1 length
  put<std::uint16_t>(out, time_interval);                                           // 3 time_interval (0.1 us)
  put<std::uint16_t>(out, dot_num);                                                 // 5 dot_num
  put<std::uint16_t>(out, 7);                                                       // 7 udp_cnt
  put<std::uint8_t>(out, 3);                                                        // 9 frame_cnt
  put<std::uint8_t>(out, data_type);                                                // 10 data_type
  put<std::uint8_t>(out, 0);                                                        // 11 time_type
  put<std::uint8_t>(out, 0);                                                        // 12 pack_info
  out.resize(out.size() + 11, 0);                                                   // 13 reserved
  put<std::uint32_t>(out, 0);                                                       // 24 crc32
  put<std::uint64_t>(out, timestamp_ns);                                            // 28 timestamp
  out.insert(out.end(), data.begin(), data.end());                                  // 36 data
  return out;
}

/// Data section of `points` in data_type 1 (int32 mm), 2 (int16 cm) or 3 (spherical).
inline std::vector<std::uint8_t> point_data(std::uint8_t data_type, const std::vector<RawPoint>& points) {
  std::vector<std::uint8_t> out;
  for (const auto& p : points) {
    if (data_type == 1) {
      put<std::int32_t>(out, static_cast<std::int32_t>(std::lround(p.x * 1000)));
      put<std::int32_t>(out, static_cast<std::int32_t>(std::lround(p.y * 1000)));
      put<std::int32_t>(out, static_cast<std::int32_t>(std::lround(p.z * 1000)));
    } else if (data_type == 2) {
      put<std::int16_t>(out, static_cast<std::int16_t>(std::lround(p.x * 100)));
      put<std::int16_t>(out, static_cast<std::int16_t>(std::lround(p.y * 100)));
      put<std::int16_t>(out, static_cast<std::int16_t>(std::lround(p.z * 100)));
    } else {
      const double r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
      const double theta = std::acos(p.z / r) * 180.0 / M_PI;  // from +z
      double phi = std::atan2(p.y, p.x) * 180.0 / M_PI;         // from +x
      if (phi < 0) phi += 360.0;
      put<std::uint32_t>(out, static_cast<std::uint32_t>(std::lround(r * 1000)));
      put<std::uint16_t>(out, static_cast<std::uint16_t>(std::lround(theta * 100)));
      put<std::uint16_t>(out, static_cast<std::uint16_t>(std::lround(phi * 100)));
    }
    put<std::uint8_t>(out, p.reflectivity);
    put<std::uint8_t>(out, p.tag);
  }
  return out;
}

/// IMU data section: gyro rad/s, acc in g, six float32.
inline std::vector<std::uint8_t> imu_data(float gx, float gy, float gz, float ax, float ay, float az) {
  std::vector<std::uint8_t> out;
  for (float v : {gx, gy, gz, ax, ay, az}) put<float>(out, v);
  return out;
}

}  // namespace fuse::test::livox
