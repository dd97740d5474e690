#include "fuse/io/mcap_source.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/recording.hpp"

namespace fuse::io {
namespace {

/// A stored rotation must be a unit quaternion to this tolerance (17-digit text is exact).
constexpr double kQuaternionNormTolerance = 1e-6;

double parse_number(const mcap::StringMap& values, const std::string& key, const std::string& where) {
  const auto it = values.find(key);
  if (it == values.end()) throw InputError(where + ": key '" + key + "' missing");
  const char* text = it->second.c_str();
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v)) {
    throw InputError(where + ": key '" + key + "' = '" + it->second + "' is not a finite number");
  }
  return v;
}

}  // namespace

Eigen::Isometry3d parse_calibration_metadata(const mcap::StringMap& values, const std::string& where) {
  const Eigen::Vector3d t(parse_number(values, "tx", where), parse_number(values, "ty", where),
                          parse_number(values, "tz", where));
  Eigen::Quaterniond q(parse_number(values, "qw", where), parse_number(values, "qx", where),
                       parse_number(values, "qy", where), parse_number(values, "qz", where));
  if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
    throw InputError(where + ": rotation quaternion has norm " + std::to_string(q.norm()) + ", expected 1");
  }
  q.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = t;
  return T;
}

McapSource::McapSource(const std::string& path, const TimeGateConfig& clock)
    : path_(path), reader_(path), validator_("MCAP '" + path + "'", clock) {
  // The channels this source decodes must carry the expected types.
  for (const auto& [id, channel] : reader_.channels()) {
    const bool imu = channel.topic == kImuTopic, scan = channel.topic == kLidarTopic;
    if (!imu && !scan) continue;
    const auto schema = reader_.schemas().find(channel.schema_id);
    const std::string where = path + ": channel '" + channel.topic + "'";
    if (channel.message_encoding != kMessageEncoding) {
      throw InputError(where + " has message encoding '" + channel.message_encoding + "', expected 'cdr'");
    }
    const std::string expected = imu ? kImuSchemaName : kLidarScanSchemaName;
    if (schema == reader_.schemas().end() || schema->second.name != expected) {
      throw InputError(where + " has schema '" + (schema == reader_.schemas().end() ? "" : schema->second.name) +
                       "', expected '" + expected + "'");
    }
  }
  for (const auto& m : reader_.metadata()) {
    if (m.name == kCalibrationMetadata) T_imu_lidar_ = parse_calibration_metadata(m.metadata, path + ": metadata '" + m.name + "'");
  }
  reader_.start();
}

std::string McapSource::describe() const {
  std::string text = "MCAP recording '" + path_ + "'";
  if (reader_.statistics()) text += " (" + std::to_string(reader_.statistics()->message_count) + " messages)";
  if (reader_.salvage_mode()) text += " (damaged or truncated: salvage mode)";
  return text;
}

std::optional<std::uint64_t> McapSource::expected_events() const {
  // Every message on the IMU and LiDAR channels, from the statistics' per-channel counts.
  const auto& stats = reader_.statistics();
  if (!stats) return std::nullopt;
  std::uint64_t n = 0;
  for (const auto& [channel, count] : stats->channel_message_counts) {
    const auto c = reader_.channels().find(channel);
    if (c != reader_.channels().end() && (c->second.topic == kImuTopic || c->second.topic == kLidarTopic)) n += count;
  }
  return n > 0 ? std::optional<std::uint64_t>(n) : std::nullopt;
}

std::optional<SensorEvent> McapSource::decode(const McapMessage& m) {
  const bool imu = m.channel->topic == kImuTopic, scan = m.channel->topic == kLidarTopic;
  if (!imu && !scan) {
    // JSON channels with a JSON Schema are views written beside the data (the Foxglove channels
    // of fuse-sim and fuse-record), not input: passed over without a count.
    if (m.channel->message_encoding == "json" && m.schema != nullptr && m.schema->encoding == "jsonschema") {
      return std::nullopt;
    }
    if (unknown_channels_.insert(m.channel->id).second) {
      validator_.count(reason::kUnknownChannel, "channel '" + m.channel->topic + "' is not read, ignored");
    }
    return std::nullopt;
  }
  const std::string schema = m.schema ? m.schema->name : "";
  SensorEvent event;
  try {
    if (imu) {
      event.kind = SensorEvent::Kind::kImu;
      event.imu = decode_imu(schema, m.data.data(), m.data.size());
    } else {
      event.kind = SensorEvent::Kind::kLidar;
      event.scan = decode_scan(schema, m.data.data(), m.data.size());
    }
  } catch (const InputError& e) {
    throw InputError(path_ + ": message on '" + m.channel->topic + "' at log time " + std::to_string(m.header.log_time) +
                     " ns: " + e.what());
  }
  return event;
}

bool McapSource::read(McapMessage& m) {
  if (read_error_) return false;
  try {
    return reader_.next(m);
  } catch (const InputError& e) {
    // Kept until the events already read are delivered (salvage of a truncated file).
    read_error_ = e;
    return false;
  }
}

bool McapSource::fill() {
  if (!lookahead_) {
    McapMessage m;
    if (!read(m)) return false;
    lookahead_ = std::move(m);
  }
  const std::uint64_t t = lookahead_->header.log_time;
  std::vector<SensorEvent> group;
  for (;;) {
    if (auto e = decode(*lookahead_)) group.push_back(std::move(*e));
    McapMessage m;
    if (!read(m)) {
      lookahead_.reset();
      break;
    }
    lookahead_ = std::move(m);
    if (lookahead_->header.log_time != t) break;
  }
  // Same arrival time: IMU samples first, so a scan sees every IMU sample up to its end.
  std::stable_sort(group.begin(), group.end(), [](const SensorEvent& a, const SensorEvent& b) {
    return a.kind == SensorEvent::Kind::kImu && b.kind != SensorEvent::Kind::kImu;
  });
  for (auto& e : group) ready_.push_back(std::move(e));
  return true;
}

bool McapSource::seek(double t) {
  if (!std::isfinite(t) || t < 0.0 || reader_.salvage_mode()) return false;
  McapReadOptions options;
  options.start_time = static_cast<std::uint64_t>(std::llround(t * 1e9));
  reader_.start(options);
  lookahead_.reset();
  ready_.clear();
  passed_.clear();
  validator_.restart();
  return true;
}

bool McapSource::next(SensorEvent& out) {
  for (;;) {
    if (!passed_.empty()) {
      out = std::move(passed_.front());
      passed_.pop_front();
      return true;
    }
    while (ready_.empty()) {
      if (fill()) continue;
      validator_.finish();
      if (read_error_) throw *read_error_;  // after every event read before the error
      return false;
    }
    SensorEvent event = std::move(ready_.front());
    ready_.pop_front();
    validator_.check(std::move(event), passed_);
  }
}

}  // namespace fuse::io
