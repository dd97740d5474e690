#include "topic_catalog.hpp"

#include <cmath>

#include "fuse/io/time_ns.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/qos.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::record {
namespace {

/// The sample's own time, for the types a replay orders by; none for the others.
std::optional<double> sensor_time(const fuse_msgs::ImuSample& m) { return m.t(); }
std::optional<double> sensor_time(const fuse_msgs::LidarScan& m) { return m.end_time(); }
template <class T>
std::optional<double> sensor_time(const T&) {
  return std::nullopt;
}

template <class T>
TopicType entry(const std::string& topic) {
  TopicType t;
  t.topic = topic;
  t.type_name = transport::MsgName<T>::value;
  t.support = transport::type_support<T>();
  t.qos = transport::topic_qos(topic);
  t.check = [](const std::uint8_t* data, std::size_t size) {
    SampleCheck result;
    T msg;
    if (!transport::deserialize(data, size, msg, &result.error)) return result;
    result.sensor_time = sensor_time(msg);
    if (result.sensor_time) {
      const double s = *result.sensor_time;
      // It becomes the MCAP log time (uint64 ns): it must be a representable, finite time.
      if (!std::isfinite(s) || s < 0.0 || s > io::kMaxTimestampSeconds) {
        result.error = "sample time " + std::to_string(s) + " s is not a valid timestamp";
        return result;
      }
    }
    result.ok = true;
    return result;
  };
  return t;
}

std::vector<TopicType> make_catalog() {
  namespace topics = transport::topics;
  namespace services = transport::services;
  using transport::reply_topic;
  using transport::request_topic;
  return {
      entry<fuse_msgs::ImuSample>(topics::kImu),
      entry<fuse_msgs::LidarScan>(topics::kLidarScan),
      entry<fuse_msgs::StateEstimate>(topics::kOdometry),
      entry<fuse_msgs::StateEstimate>(topics::kCorrected),
      entry<fuse_msgs::Correction>(topics::kCorrection),
      entry<fuse_msgs::MapObservation>(topics::kObservation),
      entry<fuse_msgs::WorldScan>(topics::kWorldScan),
      entry<fuse_msgs::MapChunk>(topics::kMapChunk),
      entry<fuse_msgs::MapStatus>(topics::kMapStatus),
      entry<fuse_msgs::Health>(topics::kHealth),
      entry<fuse_msgs::QueryRequest>(request_topic(services::kQuery)),
      entry<fuse_msgs::QueryReply>(reply_topic(services::kQuery)),
      entry<fuse_msgs::HistoryRequest>(request_topic(services::kHistory)),
      entry<fuse_msgs::HistoryReply>(reply_topic(services::kHistory)),
      entry<fuse_msgs::MapControlRequest>(request_topic(services::kMapControl)),
      entry<fuse_msgs::MapControlReply>(reply_topic(services::kMapControl)),
      entry<fuse_msgs::SetPoseRequest>(request_topic(services::kSetPose)),
      entry<fuse_msgs::SetPoseReply>(reply_topic(services::kSetPose)),
  };
}

}  // namespace

const std::vector<TopicType>& fuse_topics() {
  static const std::vector<TopicType> catalog = make_catalog();
  return catalog;
}

}  // namespace fuse::record
