#include "importer.hpp"

#include <cmath>
#include <vector>

#include "fuse/core/logging.hpp"
#include "fuse/core/progress.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"

namespace fuse::import {

namespace {

/// Logs the first few occurrences of each skip reason (the summary has the totals).
void note(ImportSummary& s, const char* reason, const std::string& detail) {
  const std::uint64_t n = ++s.skipped[reason];
  if (n <= 3) logger("import")->warn("skipped ({}): {}", reason, detail);
  if (n == 3) logger("import")->warn("further '{}' skips are only counted", reason);
}

std::string list_topics(const rosbag::BagReader& bag) {
  std::string out;
  for (const auto& t : bag.topics()) out += "\n  " + t.name + " [" + t.type + "]";
  return out;
}

std::size_t choose(const rosbag::BagReader& bag, const std::string& named, const char* what, const char* option,
                   bool (*accept)(const std::string&)) {
  const auto& topics = bag.topics();
  if (!named.empty()) {
    for (std::size_t i = 0; i < topics.size(); ++i) {
      if (topics[i].name != named) continue;
      if (!accept(topics[i].type)) {
        throw TopicError(std::string(option) + " " + named + " has type " + topics[i].type + ", not " + what);
      }
      return i;
    }
    throw TopicError(std::string(option) + ": the bag has no topic " + named + "; its topics:" + list_topics(bag));
  }
  std::vector<std::size_t> found;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    if (accept(topics[i].type)) found.push_back(i);
  }
  if (found.empty()) throw TopicError(std::string("the bag has no ") + what + " topic; its topics:" + list_topics(bag));
  if (found.size() > 1) {
    std::string names;
    for (auto i : found) names += " " + topics[i].name;
    throw TopicError(std::string("several ") + what + " topics (" + names + " ); choose one with " + option);
  }
  return found.front();
}

bool accept_lidar(const std::string& type) { return is_lidar_type(type); }

}  // namespace

bool is_imu_type(const std::string& type) { return rosbag::ros1_type_name(type) == "sensor_msgs/Imu"; }

bool is_lidar_type(const std::string& type, LidarKind* kind) {
  const std::string t = rosbag::ros1_type_name(type);
  LidarKind k;
  if (t == "sensor_msgs/PointCloud2") {
    k = LidarKind::kPointCloud2;
  } else if (t == "livox_ros_driver/CustomMsg" || t == "livox_ros_driver2/CustomMsg") {
    k = LidarKind::kLivoxCustom;
  } else {
    return false;
  }
  if (kind) *kind = k;
  return true;
}

TopicChoice choose_topics(const rosbag::BagReader& bag, const ImportConfig& config) {
  TopicChoice c;
  c.imu = choose(bag, config.imu_topic, "sensor_msgs/Imu", "--imu-topic", &is_imu_type);
  c.lidar = choose(bag, config.lidar_topic, "LiDAR (sensor_msgs/PointCloud2, livox_ros_driver[2]/CustomMsg)",
                   "--lidar-topic", &accept_lidar);
  is_lidar_type(bag.topics()[c.lidar].type, &c.lidar_kind);
  return c;
}

std::optional<std::uint64_t> expected_messages(const rosbag::BagReader& bag, const TopicChoice& topics) {
  const std::uint64_t imu = bag.topics()[topics.imu].message_count;
  const std::uint64_t lidar = bag.topics()[topics.lidar].message_count;
  // 0 is what the readers report when the bag declares no count: then no share can be shown.
  if (imu == 0 || lidar == 0) return std::nullopt;
  return imu + lidar;
}

ImportSummary import_bag(rosbag::BagReader& bag, const TopicChoice& topics, const ImportConfig& config,
                         io::RecordingWriter& writer) {
  ImportSummary s;
  const auto& imu_topic = bag.topics()[topics.imu];
  const auto& lidar_topic = bag.topics()[topics.lidar];
  for (std::size_t i = 0; i < bag.topics().size(); ++i) {
    if (i != topics.imu && i != topics.lidar) s.other_topic_messages += bag.topics()[i].message_count;
  }
  bag.start({imu_topic.name, lidar_topic.name});
  rosbag::BagMessage m;
  double last_imu_t = -INFINITY, last_scan_end = -INFINITY, accel_sum = 0.0;
  std::uint64_t imu_seq = 0, scan_seq = 0;
  Progress progress("import", expected_messages(bag, topics));
  try {
    while (bag.next(m)) {
      // Messages read so far (this one included) and its receive time: the speed against real time.
      progress.update(s.imu_messages + s.lidar_messages + 1, 1e-9 * static_cast<double>(m.time_ns));
      const auto& topic = bag.topics()[m.topic];
      const std::string where = topic.name + " message at " + std::to_string(m.time_ns) + " ns";
      if (m.topic == topics.imu) {
        ++s.imu_messages;
        ImuSample sample;
        try {
          sample = rosbag::imu_to_sample(rosbag::decode_imu(m.data.data(), m.data.size(), topic.serialization, where),
                                         config.accel_scale);
        } catch (const io::InputError& e) {
          note(s, skip::kMalformedImu, e.what());
          continue;
        }
        if (!(sample.t > last_imu_t)) {
          note(s, skip::kImuTimeNotIncreasing, where + ": stamp not after the previous IMU sample");
          continue;
        }
        last_imu_t = sample.t;
        sample.sequence = imu_seq++;
        writer.write(sample);
        accel_sum += sample.accel.norm();
        ++s.imu_written;
      } else if (m.topic == topics.lidar) {
        ++s.lidar_messages;
        LidarScan scan;
        try {
          if (topics.lidar_kind == LidarKind::kLivoxCustom) {
            scan = rosbag::livox_to_scan(
                rosbag::decode_livox_custom(m.data.data(), m.data.size(), lidar_topic.serialization, where), s.points);
          } else {
            const auto cloud = rosbag::decode_point_cloud2(m.data.data(), m.data.size(), lidar_topic.serialization, where);
            try {
              scan = rosbag::cloud_to_scan(cloud, config.time_field, s.points, where);
            } catch (const io::InputError& e) {
              note(s, skip::kUnusableCloud, e.what());
              continue;
            }
          }
        } catch (const io::InputError& e) {
          note(s, skip::kMalformedCloud, e.what());
          continue;
        }
        if (scan.points.empty()) {
          note(s, skip::kEmptyScan, where + ": no valid points");
          continue;
        }
        if (!(scan.t_end > last_scan_end)) {
          note(s, skip::kScanTimeNotIncreasing, where + ": scan ends not after the previous scan");
          continue;
        }
        last_scan_end = scan.t_end;
        scan.sequence = scan_seq++;
        writer.write(scan);
        ++s.scans_written;
      }
    }
  } catch (const io::InputError& e) {
    s.error = e.what();
  }
  s.imu_mean_accel_norm = s.imu_written ? accel_sum / static_cast<double>(s.imu_written) : 0.0;
  return s;
}

}  // namespace fuse::import
