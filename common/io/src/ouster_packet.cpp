#include "fuse/io/ouster_packet.hpp"

#include <cmath>
#include <cstring>

namespace fuse::io::ouster {

namespace {

template <typename T>
T le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // little-endian host (static_assert in byte_io.hpp)
  return v;
}

std::uint64_t le_bytes(const std::uint8_t* p, int n) {
  std::uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

bool decode_lidar(const std::uint8_t* data, std::size_t size, const Metadata& meta, LidarPacket& out,
                  Rejection& why) {
  const std::size_t expected = meta.lidar_packet_size();
  if (size != expected) {
    why = {reject::kLidarSize, "lidar packet of " + std::to_string(size) + " bytes, metadata's profile " +
                                   profile_name(meta.lidar_profile) + " with " + std::to_string(meta.pixels_per_column) +
                                   " pixels x " + std::to_string(meta.columns_per_packet) + " columns expects " +
                                   std::to_string(expected)};
    return false;
  }
  const auto cpp = static_cast<std::size_t>(meta.columns_per_packet);
  const auto ppc = static_cast<std::size_t>(meta.pixels_per_column);
  out.columns.resize(cpp);
  out.pixels.resize(cpp * ppc);
  const bool legacy = meta.lidar_profile == LidarProfile::kLegacy;
  std::size_t off = 0;
  if (!legacy) {
    const auto type = le<std::uint16_t>(data);
    if (type != 1) {
      why = {reject::kPacketType, "packet type " + std::to_string(type) + " where a lidar packet has 1"};
      return false;
    }
    out.frame_id = le<std::uint16_t>(data + 2);
    out.init_id = static_cast<std::uint32_t>(le_bytes(data + 4, 3));
    out.serial = le_bytes(data + 7, 5);
    if ((meta.init_id != 0 && out.init_id != meta.init_id) || (meta.serial != 0 && out.serial != meta.serial)) {
      why = {reject::kOtherSensor, "packet of sensor " + std::to_string(out.serial) + " (init id " +
                                       std::to_string(out.init_id) + "), metadata is for " + std::to_string(meta.serial) +
                                       " (init id " + std::to_string(meta.init_id) + ")"};
      return false;
    }
    off = 32;
  }
  for (std::size_t c = 0; c < cpp; ++c) {
    Column& col = out.columns[c];
    const std::uint8_t* h = data + off;
    col.timestamp_ns = le<std::uint64_t>(h);
    col.measurement_id = le<std::uint16_t>(h + 8);
    Pixel* px = &out.pixels[c * ppc];
    if (legacy) {
      col.frame_id = le<std::uint16_t>(h + 10);
      const std::uint8_t* p = h + 16;
      for (std::size_t b = 0; b < ppc; ++b, p += 12) {
        px[b].range_mm = le<std::uint32_t>(p) & 0xFFFFF;
        px[b].reflectivity = le<std::uint16_t>(p + 4);
        px[b].signal = le<std::uint16_t>(p + 6);
        px[b].near_ir = le<std::uint16_t>(p + 8);
      }
      col.valid = le<std::uint32_t>(p) == 0xFFFFFFFFu;
      off += 16 + ppc * 12 + 4;
      if (c == 0) out.frame_id = col.frame_id;
    } else {
      col.frame_id = out.frame_id;
      col.valid = (le<std::uint16_t>(h + 10) & 0x1) != 0;
      const std::uint8_t* p = h + 12;
      switch (meta.lidar_profile) {
        case LidarProfile::kRng19Rfl8Sig16Nir16:
          for (std::size_t b = 0; b < ppc; ++b, p += 12) {
            px[b].range_mm = le<std::uint32_t>(p) & 0x7FFFF;
            px[b].reflectivity = p[4];
            px[b].signal = le<std::uint16_t>(p + 6);
            px[b].near_ir = le<std::uint16_t>(p + 8);
          }
          break;
        case LidarProfile::kRng15Rfl8Nir8:
          for (std::size_t b = 0; b < ppc; ++b, p += 4) {
            px[b].range_mm = static_cast<std::uint32_t>(le<std::uint16_t>(p) & 0x7FFF) * 8;
            px[b].reflectivity = p[2];
            px[b].signal = 0;
            px[b].near_ir = p[3];
          }
          break;
        case LidarProfile::kRng19Rfl8Sig16Nir16Dual:
          for (std::size_t b = 0; b < ppc; ++b, p += 16) {
            px[b].range_mm = le<std::uint32_t>(p) & 0x7FFFF;
            px[b].reflectivity = p[3];
            px[b].signal = le<std::uint16_t>(p + 8);
            px[b].near_ir = le<std::uint16_t>(p + 12);
          }
          break;
        case LidarProfile::kLegacy:
          break;
      }
      off = static_cast<std::size_t>(p - data);
    }
    if (col.valid && col.measurement_id >= meta.columns_per_frame) {
      why = {reject::kMeasurementId, "measurement id " + std::to_string(col.measurement_id) + " in a frame of " +
                                         std::to_string(meta.columns_per_frame) + " columns"};
      return false;
    }
  }
  return true;
}

bool decode_imu(const std::uint8_t* data, std::size_t size, ImuSample& out, Rejection& why) {
  if (size != kImuPacketSize) {
    why = {reject::kImuSize, "IMU packet of " + std::to_string(size) + " bytes, the LEGACY IMU profile has " +
                                 std::to_string(kImuPacketSize)};
    return false;
  }
  const auto gyro_ts = le<std::uint64_t>(data + 16);
  float v[6];
  std::memcpy(v, data + 24, sizeof v);
  for (float f : v) {
    if (!std::isfinite(f)) {
      why = {reject::kImuValues, "IMU packet with a non-finite value"};
      return false;
    }
  }
  out.t = static_cast<double>(gyro_ts) * 1e-9;
  out.accel = Eigen::Vector3d(v[0], v[1], v[2]) * kStandardGravity;
  out.gyro = Eigen::Vector3d(v[3], v[4], v[5]) * kDegToRad;
  return true;
}

}  // namespace fuse::io::ouster
