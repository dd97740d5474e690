// Livox SDK2 point cloud and IMU UDP packets (Livox LiDAR Communication Protocol – Mid-360,
// "Point Cloud & IMU Data Protocol"), little-endian:
//
//   offset size field
//   0      1    version        packet protocol version (0)
//   1      2    length         bytes of the whole UDP payload, header included
//   3      2    time_interval  time from the packet's first to its last point, unit 0.1 µs
//   5      2    dot_num        number of points (1 for IMU)
//   7      2    udp_cnt        packet counter
//   9      1    frame_cnt      frame counter
//   10     1    data_type      0 IMU, 1 cartesian int32 mm, 2 cartesian int16 cm, 3 spherical
//   11     1    time_type      0 time since power-on, 1 PTP/gPTP, 2 GPS
//   12     1    pack_info      (tag type and flags)
//   13     11   reserved
//   24     4    crc32          over timestamp + data (not checked here: see livox_packet.cpp)
//   28     8    timestamp      ns, of the first point
//   36     ...  data           dot_num points of the data_type's size
//
// Points: type 1 {int32 x, y, z (mm); uint8 reflectivity, tag} (14 bytes); type 2 {int16 x, y, z
// (cm); uint8 reflectivity, tag} (8 bytes); type 3 {uint32 depth (mm); uint16 theta, phi (0.01°);
// uint8 reflectivity, tag} (10 bytes). IMU (type 0): float gyro x, y, z (rad/s), acc x, y, z (g).
// Point i is taken at timestamp + i * time_interval / dot_num.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"

namespace fuse::io::livox {

inline constexpr std::size_t kHeaderSize = 36;
inline constexpr std::uint8_t kProtocolVersion = 0;
inline constexpr std::uint16_t kDefaultPointPort = 56301;
inline constexpr std::uint16_t kDefaultImuPort = 56401;
/// Standard gravity: the IMU reports acceleration in g.
inline constexpr double kStandardGravity = 9.80665;
/// time_interval unit: 0.1 µs.
inline constexpr double kTimeIntervalUnitS = 1e-7;

enum class DataType : std::uint8_t { kImu = 0, kCartesianHigh = 1, kCartesianLow = 2, kSpherical = 3 };

/// Bytes per point of a data type (IMU: one 24-byte record); 0 for an unknown type.
std::size_t point_size(std::uint8_t data_type);

struct PacketHeader {
  std::uint8_t version = 0;
  std::uint16_t length = 0;
  std::uint16_t time_interval = 0;  ///< 0.1 µs
  std::uint16_t dot_num = 0;
  std::uint16_t udp_cnt = 0;
  std::uint8_t frame_cnt = 0;
  std::uint8_t data_type = 0;
  std::uint8_t time_type = 0;
  std::uint8_t pack_info = 0;
  std::uint32_t crc32 = 0;
  std::uint64_t timestamp_ns = 0;
};

/// One decoded return: metres in the LiDAR frame, its own time (s, sensor clock).
struct Point {
  float x = 0.f, y = 0.f, z = 0.f;
  std::uint8_t reflectivity = 0;
  std::uint8_t tag = 0;
  double t = 0.0;
};

struct Packet {
  PacketHeader header;
  std::vector<Point> points;  ///< data types 1..3
  ImuSample imu;              ///< data type 0: gyro rad/s, accel m/s^2, t = timestamp
};

/// Why a packet was refused (counter keys of the live source).
namespace reject {
inline constexpr const char* kShort = "livox_short_packet";
inline constexpr const char* kLengthMismatch = "livox_length_mismatch";
inline constexpr const char* kBadVersion = "livox_bad_version";
inline constexpr const char* kUnknownDataType = "livox_unknown_data_type";
inline constexpr const char* kDotNumMismatch = "livox_dot_num_mismatch";
inline constexpr const char* kNonFiniteImu = "livox_non_finite_imu";
}  // namespace reject

struct DecodeError {
  std::string reason;  ///< one of reject::*
  std::string message;
};

/// Decodes one UDP payload. Returns false with the reason filled in (never throws, never reads
/// outside [data, data + size)).
bool decode_packet(const std::uint8_t* data, std::size_t size, Packet& out, DecodeError& error);

/// Writes a header and payload as the protocol lays them out (tests, tools): `payload` is the
/// data section; length is computed. crc32 is written as given.
std::vector<std::uint8_t> encode_packet(const PacketHeader& header, const std::vector<std::uint8_t>& payload);

}  // namespace fuse::io::livox
