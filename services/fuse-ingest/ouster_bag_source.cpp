#include "ouster_bag_source.hpp"

#include "fuse/core/logging.hpp"
#include "fuse/io/ouster_pcap_source.hpp"
#include "fuse/rosbag/message_reader.hpp"

namespace fuse::service {

namespace {

constexpr const char* kPacketType = "ouster_ros/PacketMsg";
constexpr const char* kStringType = "std_msgs/String";

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// The one topic of `type` whose name ends in `suffix`; throws naming the candidates.
std::optional<std::size_t> pick(const std::vector<rosbag::BagTopic>& topics, const char* type,
                                const std::string& suffix, const std::string& bag, bool required) {
  std::vector<std::size_t> found;
  std::string all;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    if (rosbag::ros1_type_name(topics[i].type) != type) continue;
    all += (all.empty() ? "" : ", ") + topics[i].name;
    if (ends_with(topics[i].name, suffix)) found.push_back(i);
  }
  if (found.size() == 1) return found.front();
  if (found.empty() && !required) return std::nullopt;
  throw io::InputError("Ouster bag " + bag + ": " + std::to_string(found.size()) + " " + type + " topics end in '" +
                       suffix + "' (topics of that type: " + (all.empty() ? "none" : all) + ")");
}

/// The payload of one ouster_ros/PacketMsg (uint8[] buf) or std_msgs/String (string data).
std::vector<std::uint8_t> field(const rosbag::BagMessage& m, rosbag::Serialization s, const std::string& context) {
  rosbag::MessageReader r(m.data.data(), m.data.size(), s, context);
  const std::uint32_t n = r.sequence_length(1);
  const std::uint8_t* p = r.bytes(n);
  return std::vector<std::uint8_t>(p, p + n);
}

}  // namespace

bool OusterBagSource::holds_ouster_packets(const std::string& bag) {
  auto reader = rosbag::open_bag(bag);
  for (const auto& t : reader->topics()) {
    if (rosbag::ros1_type_name(t.type) == kPacketType) return true;
  }
  return false;
}

OusterBagSource::OusterBagSource(const std::string& bag, const std::string& metadata_file)
    : bag_path_(bag), bag_(rosbag::open_bag(bag)), validator_("Ouster bag " + bag) {
  const auto& topics = bag_->topics();
  lidar_topic_ = *pick(topics, kPacketType, "lidar_packets", bag, true);
  if (auto imu = pick(topics, kPacketType, "imu_packets", bag, false)) {
    imu_topic_ = *imu;
    have_imu_topic_ = true;
  }
  if (!metadata_file.empty()) {
    meta_ = io::load_ouster_metadata(metadata_file, std::nullopt, std::nullopt);
    metadata_source_ = metadata_file;
  } else {
    const std::size_t mt = *pick(topics, kStringType, "metadata", bag, true);
    bag_->start({topics[mt].name});
    rosbag::BagMessage m;
    if (!bag_->next(m)) throw io::InputError("Ouster bag " + bag + ": no message on " + topics[mt].name);
    const auto text = field(m, topics[mt].serialization, topics[mt].name);
    meta_ = io::ouster::parse_metadata(std::string(text.begin(), text.end()), bag + " " + topics[mt].name);
    metadata_source_ = topics[mt].name;
  }
  // Each topic stands for a port: lidar packets to the lidar port, IMU packets to the IMU port.
  if (meta_.udp_port_lidar == 0) meta_.udp_port_lidar = io::ouster::kDefaultLidarPort;
  if (meta_.udp_port_imu == 0 || meta_.udp_port_imu == meta_.udp_port_lidar) {
    meta_.udp_port_imu = static_cast<std::uint16_t>(meta_.udp_port_lidar + 1);
  }
  stream_ = std::make_unique<io::ouster::Stream>(meta_, validator_);
  std::vector<std::string> names = {topics[lidar_topic_].name};
  if (have_imu_topic_) names.push_back(topics[imu_topic_].name);
  bag_->start(names);
  logger("ouster")->info("reading Ouster packets from {} ({}{}), metadata {}: {} x {} columns, profile {}", bag,
                         topics[lidar_topic_].name, have_imu_topic_ ? ", " + topics[imu_topic_].name : "",
                         metadata_source_, meta_.pixels_per_column, meta_.window_columns(),
                         io::ouster::profile_name(meta_.lidar_profile));
}

std::string OusterBagSource::describe() const { return "Ouster bag " + bag_path_ + " (metadata " + metadata_source_ + ")"; }

bool OusterBagSource::next(io::SensorEvent& out) {
  const auto& topics = bag_->topics();
  const std::size_t lidar_size = meta_.lidar_packet_size();
  for (;;) {
    if (!passed_.empty()) {
      out = std::move(passed_.front());
      passed_.pop_front();
      return true;
    }
    if (!ready_.empty()) {
      io::SensorEvent event = std::move(ready_.front());
      ready_.pop_front();
      validator_.check(std::move(event), passed_);
      continue;
    }
    if (finished_) {
      validator_.finish();
      if (!error_.empty()) throw io::InputError(error_);
      return false;
    }
    rosbag::BagMessage m;
    if (bag_->next(m)) {
      const bool lidar = m.topic == lidar_topic_;
      std::vector<std::uint8_t> buf;
      try {
        buf = field(m, topics[m.topic].serialization, topics[m.topic].name);
      } catch (const io::InputError& e) {
        validator_.count("ouster_bag_bad_message", e.what());
        continue;
      }
      if (lidar && buf.size() == lidar_size + 1) buf.pop_back();
      if (!lidar && buf.size() == io::ouster::kImuPacketSize + 1) buf.pop_back();
      stream_->handle(buf.data(), buf.size(), 0, lidar ? meta_.udp_port_lidar : meta_.udp_port_imu, ready_);
      continue;
    }
    finished_ = true;
    stream_->finish(ready_);
    if (stream_->scans() == 0) {
      error_ = "Ouster bag " + bag_path_ + ": no full frame (" + std::to_string(stream_->lidar_packets()) +
               " lidar packets decoded" +
               (stream_->first_lidar_rejection().empty() ? "" : "; " + stream_->first_lidar_rejection()) +
               (stream_->last_dropped_frame().empty() ? "" : "; " + stream_->last_dropped_frame()) + ")";
    }
  }
}

}  // namespace fuse::service
