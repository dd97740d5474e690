// Ouster sensor metadata (the JSON the sensor serves and ouster-sdk saves beside a capture;
// Ouster Sensor Docs, "HTTP API Reference": sensor_info, beam_intrinsics, imu_intrinsics,
// lidar_intrinsics, lidar_data_format, config_params). Two layouts exist and both are read:
//
//   flat (firmware 1.x-2.x, ouster_client ≤ 0.3): beam_altitude_angles, beam_azimuth_angles,
//     lidar_origin_to_beam_origin_mm, lidar_to_sensor_transform, imu_to_sensor_transform,
//     lidar_mode, prod_sn, initialization_id, udp_port_lidar/imu at the top, and data_format
//     {columns_per_frame, columns_per_packet, pixels_per_column, column_window,
//     udp_profile_lidar, udp_profile_imu} (absent before firmware 2.0: legacy packets, 16
//     columns per packet, one pixel per beam, the whole revolution);
//   nested (firmware 2.4+/3.x, ouster-sdk ≥ 0.5): the same quantities under beam_intrinsics
//     (plus beam_to_lidar_transform), lidar_intrinsics, imu_intrinsics, lidar_data_format,
//     config_params (lidar_mode, UDP ports and profiles) and sensor_info.
//
// Transforms are 4x4 row-major with translations in millimetres. A missing or ill-typed field
// raises InputError naming it (with its JSON path); nothing is guessed.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace fuse::io::ouster {

/// UDP lidar packet profiles read here (lidar_data_format.udp_profile_lidar).
enum class LidarProfile {
  kLegacy,              ///< firmware 1.x/2.x packets: no packet header, 12-byte pixels, column footer
  kRng19Rfl8Sig16Nir16,  ///< single return, 12-byte pixels
  kRng15Rfl8Nir8,        ///< low bandwidth, 4-byte pixels, range in 8 mm units
  kRng19Rfl8Sig16Nir16Dual,  ///< two returns, 16-byte pixels (the first, strongest, return is used)
};
/// IMU packet profiles read here (udp_profile_imu): only the legacy 48-byte packet.
enum class ImuProfile { kLegacy };

const char* profile_name(LidarProfile p);

inline constexpr std::uint16_t kDefaultLidarPort = 7502;
inline constexpr std::uint16_t kDefaultImuPort = 7503;

struct Metadata {
  std::string name;       ///< file it came from (for messages)
  std::string prod_line;  ///< e.g. "OS-1-128"; may be empty
  std::string firmware;   ///< build_rev; may be empty
  std::uint64_t serial = 0;       ///< prod_sn; 0 when absent
  std::uint32_t init_id = 0;      ///< initialization_id; 0 when absent
  std::string lidar_mode;         ///< "1024x10"
  int columns_per_frame = 0;      ///< from lidar_mode / columns_per_frame
  int frequency_hz = 0;           ///< from lidar_mode
  int columns_per_packet = 16;
  int pixels_per_column = 0;
  int column_window_first = 0, column_window_last = 0;  ///< inclusive; may wrap (first > last)
  LidarProfile lidar_profile = LidarProfile::kLegacy;
  ImuProfile imu_profile = ImuProfile::kLegacy;
  std::vector<double> beam_altitude_deg, beam_azimuth_deg;
  double lidar_origin_to_beam_origin_mm = 0.0;
  /// Beam origin offset in the lidar frame (mm): x along the encoder direction, z up; from
  /// beam_to_lidar_transform when given, else (lidar_origin_to_beam_origin_mm, 0).
  double beam_offset_x_mm = 0.0, beam_offset_z_mm = 0.0;
  Eigen::Matrix4d lidar_to_sensor = Eigen::Matrix4d::Identity();  ///< mm
  Eigen::Matrix4d imu_to_sensor = Eigen::Matrix4d::Identity();    ///< mm
  std::uint16_t udp_port_lidar = kDefaultLidarPort;  ///< 0: the lidar stream is switched off
  std::uint16_t udp_port_imu = kDefaultImuPort;

  /// Columns in the column window (a full frame has this many).
  int window_columns() const;
  bool in_window(int measurement_id) const;
  /// Bytes of one lidar packet of this profile and size.
  std::size_t lidar_packet_size() const;
  /// Sensor frame → IMU frame (metres): inv(imu_to_sensor).
  Eigen::Isometry3d T_imu_sensor() const;
  /// Ouster lidar frame → IMU frame (metres): inv(imu_to_sensor) · lidar_to_sensor.
  Eigen::Isometry3d T_imu_lidar() const;
};

/// Parses metadata JSON text; `name` names it in messages. Throws InputError.
Metadata parse_metadata(const std::string& json_text, const std::string& name);
/// Reads and parses a metadata file. Throws InputError.
Metadata load_metadata(const std::string& path);

}  // namespace fuse::io::ouster
