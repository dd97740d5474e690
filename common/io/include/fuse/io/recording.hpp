// The project's recording format: MCAP whose channels carry CDR-serialised fuse_msgs samples
// (message encoding "cdr") with the IDL text as schema (schema encoding "omgidl").
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>

#include "fuse/core/types.hpp"
#include "fuse/io/sensor_source.hpp"

namespace fuse::io {

/// Topic (channel) names used in recordings; the same names are the DDS topics.
inline constexpr const char* kImuTopic = "imu";
inline constexpr const char* kLidarTopic = "lidar/scan";
/// MCAP metadata record holding the LiDAR-IMU extrinsic, keys tx ty tz qx qy qz qw.
inline constexpr const char* kCalibrationMetadata = "fuse.calibration";

enum class Compression { kNone, kZstd, kLz4 };

struct RecordingWriterConfig {
  Compression compression = Compression::kZstd;
  std::size_t chunk_size_bytes = 4u << 20;  ///< close a chunk once its records exceed this
  std::string imu_frame = "imu";
  std::string lidar_frame = "lidar";
};

/// Writes ImuSample / LidarScan as CDR samples into an MCAP file (chunked, indexed, summary).
class RecordingWriter {
 public:
  RecordingWriter(const std::string& path, const RecordingWriterConfig& config = {});
  ~RecordingWriter();  ///< closes the file if close() was not called
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  void set_calibration(const Eigen::Isometry3d& T_imu_lidar);
  /// Another channel beside imu and lidar/scan: JSON messages with a JSON Schema (schema
  /// encoding jsonschema, message encoding json), e.g. the Foxglove channels. Returns its id.
  std::uint16_t add_json_channel(const std::string& topic, const std::string& schema_name, const std::string& schema);
  /// One message of a channel from add_json_channel(), at log_time (ns).
  void write_json(std::uint16_t channel, std::uint64_t log_time, const std::string& json);
  void write(const ImuSample& imu);
  void write(const LidarScan& scan);  ///< log time = scan end time (arrival)
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fuse::io
