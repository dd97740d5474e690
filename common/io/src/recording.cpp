#include "fuse/io/recording.hpp"

#include <map>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>

#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/mcap_writer.hpp"
#include "fuse/io/time_ns.hpp"
#include "fuse_idl_text.hpp"

namespace fuse::io {
namespace {

/// Digits that make a double round-trip exactly through its decimal text.
constexpr int kRoundTripDigits = 17;

std::string exact(double v) { return fmt::format("{:.{}g}", v, kRoundTripDigits); }

}  // namespace

struct RecordingWriter::Impl {
  Impl(const std::string& path, const RecordingWriterConfig& c) : config(c), writer(path, options(c)) {
    const auto imu_schema = writer.add_schema(kImuSchemaName, kSchemaEncoding, fuse::msgs::kIdlText);
    const auto scan_schema = writer.add_schema(kLidarScanSchemaName, kSchemaEncoding, fuse::msgs::kIdlText);
    imu_channel = writer.add_channel(imu_schema, kImuTopic, kMessageEncoding);
    lidar_channel = writer.add_channel(scan_schema, kLidarTopic, kMessageEncoding);
  }
  static McapWriterOptions options(const RecordingWriterConfig& c) {
    McapWriterOptions o;
    o.compression = c.compression;
    o.chunk_size_bytes = c.chunk_size_bytes;
    return o;
  }
  void write(std::uint16_t channel, std::uint32_t& sequence, double t, const std::vector<std::uint8_t>& bytes) {
    const std::uint64_t ns = seconds_to_ns(t);
    writer.write_message(channel, sequence++, ns, ns, bytes.data(), bytes.size());
  }

  RecordingWriterConfig config;
  McapWriter writer;
  std::uint16_t imu_channel = 0, lidar_channel = 0;
  std::uint32_t imu_sequence = 0, lidar_sequence = 0;
  std::map<std::uint16_t, std::uint32_t> json_sequences;  ///< per add_json_channel() channel
};

RecordingWriter::RecordingWriter(const std::string& path, const RecordingWriterConfig& config)
    : impl_(std::make_unique<Impl>(path, config)) {}

RecordingWriter::~RecordingWriter() = default;  // the McapWriter closes the file

void RecordingWriter::set_calibration(const Eigen::Isometry3d& T_imu_lidar) {
  const Eigen::Vector3d t = T_imu_lidar.translation();
  const Eigen::Quaterniond q(T_imu_lidar.rotation());
  impl_->writer.write_metadata(kCalibrationMetadata, {{"tx", exact(t.x())},
                                                      {"ty", exact(t.y())},
                                                      {"tz", exact(t.z())},
                                                      {"qx", exact(q.x())},
                                                      {"qy", exact(q.y())},
                                                      {"qz", exact(q.z())},
                                                      {"qw", exact(q.w())}});
}

std::uint16_t RecordingWriter::add_json_channel(const std::string& topic, const std::string& schema_name,
                                                const std::string& schema) {
  const std::uint16_t schema_id = impl_->writer.add_schema(schema_name, "jsonschema", schema);
  const std::uint16_t channel = impl_->writer.add_channel(schema_id, topic, "json");
  impl_->json_sequences[channel] = 0;
  return channel;
}

void RecordingWriter::write_json(std::uint16_t channel, std::uint64_t log_time, const std::string& json) {
  const auto it = impl_->json_sequences.find(channel);
  if (it == impl_->json_sequences.end()) throw std::invalid_argument("write_json: channel " + std::to_string(channel) + " is not a JSON channel");
  impl_->writer.write_message(channel, it->second++, log_time, log_time, reinterpret_cast<const std::uint8_t*>(json.data()),
                              json.size());
}

void RecordingWriter::write(const ImuSample& imu) {
  impl_->write(impl_->imu_channel, impl_->imu_sequence, imu.t, encode_imu(imu, impl_->config.imu_frame));
}

void RecordingWriter::write(const LidarScan& scan) {
  impl_->write(impl_->lidar_channel, impl_->lidar_sequence, scan.t_end, encode_scan(scan, impl_->config.lidar_frame));
}

void RecordingWriter::close() { impl_->writer.close(); }

}  // namespace fuse::io
