// Ouster lidar and IMU UDP packets (Ouster Sensor Docs, "Sensor Data" / "Lidar Data Packet
// Format" and "IMU Data Format"), little-endian, laid out by the metadata's packet profile:
//
// LEGACY lidar packet: columns_per_packet columns, each
//   0   u64 timestamp (ns)   8  u16 measurement id   10 u16 frame id   12 u32 encoder count
//   16  pixels_per_column × 12-byte pixel: u32 range (bits 0..19, mm), u16 reflectivity,
//       u16 signal, u16 near-IR, u16 unused
//   end u32 column status: 0xFFFFFFFF valid, else the column holds no data
//
// Profile lidar packets (RNG19_RFL8_SIG16_NIR16, RNG15_RFL8_NIR8, RNG19_RFL8_SIG16_NIR16_DUAL):
//   32-byte packet header: u16 packet type (1 = lidar), u16 frame id, u24 initialization id,
//     u40 serial number, then status bytes (shot limiting, thermal shutdown; not read)
//   columns_per_packet columns: 12-byte header {u64 timestamp (ns), u16 measurement id,
//     u16 status (bit 0: valid)} then pixels_per_column pixels of the profile:
//       RNG19_RFL8_SIG16_NIR16 (12 B): u32 range bits 0..18 (mm), u8 reflectivity, u8 -,
//         u16 signal, u16 near-IR, u16 -
//       RNG15_RFL8_NIR8 (4 B): u16 range bits 0..14 in units of 8 mm, u8 reflectivity, u8 near-IR
//       RNG19_RFL8_SIG16_NIR16_DUAL (16 B): u32 {range bits 0..18 (mm), reflectivity bits 24..31}
//         for the first return, the same for the second, u16 signal 1, u16 signal 2, u16 near-IR,
//         u16 -. Only the first (strongest) return is used.
//   32-byte packet footer (not read).
//
// LEGACY IMU packet (48 bytes): u64 system time, u64 accelerometer read time, u64 gyroscope
// read time (ns), f32 acceleration x, y, z (g), f32 angular velocity x, y, z (deg/s).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/io/ouster_metadata.hpp"

namespace fuse::io::ouster {

inline constexpr std::size_t kImuPacketSize = 48;
inline constexpr double kStandardGravity = 9.80665;  ///< the IMU reports acceleration in g

/// Why a packet was refused (counter keys of the sources).
namespace reject {
inline constexpr const char* kLidarSize = "ouster_lidar_packet_size";      ///< does not fit the metadata
inline constexpr const char* kPacketType = "ouster_lidar_packet_type";     ///< header type is not 1
inline constexpr const char* kOtherSensor = "ouster_other_sensor";         ///< init id / serial not ours
inline constexpr const char* kMeasurementId = "ouster_bad_measurement_id"; ///< ≥ columns_per_frame
inline constexpr const char* kImuSize = "ouster_imu_packet_size";
inline constexpr const char* kImuValues = "ouster_imu_not_finite";
}  // namespace reject

struct Pixel {
  std::uint32_t range_mm = 0;  ///< 0: no return
  std::uint16_t reflectivity = 0;
  std::uint16_t signal = 0;
  std::uint16_t near_ir = 0;
};

struct Column {
  std::uint64_t timestamp_ns = 0;
  std::uint16_t measurement_id = 0;
  std::uint16_t frame_id = 0;
  bool valid = false;
};

struct LidarPacket {
  std::uint16_t frame_id = 0;
  std::uint32_t init_id = 0;  ///< profile packets only
  std::uint64_t serial = 0;   ///< profile packets only
  std::vector<Column> columns;
  std::vector<Pixel> pixels;  ///< column-major: pixels[c * pixels_per_column + beam]
};

/// Why decoding failed: a counter key (reject::*) and a message for the log.
struct Rejection {
  const char* reason = nullptr;
  std::string detail;
};

/// Decodes a lidar packet laid out as `meta` says. False (with `why`) when it does not fit:
/// wrong size for the profile, not a lidar packet, another sensor's init id / serial, or a
/// measurement id outside the frame.
bool decode_lidar(const std::uint8_t* data, std::size_t size, const Metadata& meta, LidarPacket& out,
                  Rejection& why);

/// Decodes a LEGACY IMU packet in the IMU frame: accel in m/s², gyro in rad/s, t = the
/// gyroscope read time (s). False (with `why`) for a wrong size or non-finite values.
bool decode_imu(const std::uint8_t* data, std::size_t size, ImuSample& out, Rejection& why);

}  // namespace fuse::io::ouster
