// fuse-record's output: numbered MCAP files (PREFIX_000.mcap, PREFIX_001.mcap, ...) in the
// project's recording format (schema encoding omgidl with the IDL text, message encoding cdr;
// channel per topic, imu and lidar/scan as fuse-sim writes them). A new file starts once the
// current one holds --max-bytes of message data or has been open --max-seconds. Every file is
// complete on its own: it has every channel, the calibration record when one is known, and is
// closed with its summary and footer before the next one starts.
// Beside the topics, extra channels of another encoding (the Foxglove channels: json with a
// jsonschema schema) can be written; a latched extra channel's last message is written again at
// the start of every later file, so that each file draws on its own (the map, /tf_static).
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuse/foxglove/server.hpp"
#include "fuse/io/mcap_writer.hpp"
#include "topic_catalog.hpp"

namespace fuse::record {

struct RotationOptions {
  std::string dir;
  std::string prefix = "recording";
  std::uint64_t max_bytes = 0;  ///< message bytes (as received, uncompressed) per file; 0 = no limit
  double max_seconds = 0.0;     ///< wall-clock seconds per file; 0 = no limit
  io::Compression compression = io::Compression::kZstd;
  std::optional<Eigen::Isometry3d> calibration;  ///< written as the fuse.calibration record
  std::vector<foxglove::Channel> extra_channels;  ///< written with write_extra()
};

struct FileSummary {
  std::string path;
  std::uint64_t messages = 0;  ///< recorded samples
  std::uint64_t bytes = 0;     ///< message bytes (of both kinds)
  std::uint64_t extra_messages = 0;  ///< messages of the extra (Foxglove) channels
};

class RotatingWriter {
 public:
  /// Creates the directory and opens the first file; throws std::runtime_error when it cannot.
  RotatingWriter(const RotationOptions& options, std::vector<const TopicType*> topics);
  ~RotatingWriter();
  /// Writes one message of topics[topic] (times in ns), starting a new file first when the size
  /// limit would be passed.
  void write(std::size_t topic, std::uint64_t log_time, const std::uint8_t* data, std::size_t size);
  /// Writes one message of options.extra_channels[channel].
  void write_extra(std::size_t channel, std::uint64_t log_time, const std::string& payload);
  /// Starts a new file when the current one has been open for max_seconds.
  void rotate_if_due(std::chrono::steady_clock::time_point now);
  void close();
  const std::vector<FileSummary>& files() const { return files_; }

 private:
  void open_next();
  void close_current();
  /// Rotates first when the size limit would be passed; then, in a new file, writes the latched
  /// extra channels' last messages at log_time.
  void before_message(std::uint64_t log_time, std::size_t size);
  void put(std::uint16_t channel, std::uint32_t& sequence, std::uint64_t log_time, const std::uint8_t* data,
           std::size_t size, bool extra);

  RotationOptions options_;
  std::vector<const TopicType*> topics_;
  std::unique_ptr<io::McapWriter> writer_;
  std::vector<std::uint16_t> channels_;   ///< channel id per topic in the open file
  std::vector<std::uint32_t> sequences_;  ///< per channel, within the open file
  std::vector<std::uint16_t> extra_ids_;        ///< channel id per extra channel in the open file
  std::vector<std::uint32_t> extra_sequences_;
  std::vector<std::optional<std::string>> latched_;  ///< last message of each latched extra channel
  bool latched_due_ = false;                         ///< a new file has not had them yet
  std::chrono::steady_clock::time_point opened_;
  std::vector<FileSummary> files_;
};

}  // namespace fuse::record
