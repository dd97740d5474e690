// ROS 2 writers of one service (fuse/service/ros2_output.hpp).
#include "fuse/service/ros2_output.hpp"

#include <chrono>

#include "fuse/core/logging.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/health.hpp"
#include "fuse/transport/ros2.hpp"

namespace fuse::service {
namespace {

namespace ros2 = transport::ros2;

// Largest samples the writers take: a map of 16 M points, a scan of 1 M, small messages 64 kB.
constexpr std::size_t kMaxMapBytes = std::size_t{200} << 20;
constexpr std::size_t kMaxScanBytes = std::size_t{16} << 20;
constexpr std::size_t kMaxSmallBytes = std::size_t{64} << 10;

std::unique_ptr<transport::RawWriter> writer(transport::Participant& p, const std::string& topic, const char* type,
                                             std::size_t max_bytes, const transport::TopicQos& qos) {
  return p.create_writer(ros2::dds_topic(topic), ros2::type_support(type, max_bytes), qos);
}

}  // namespace

Ros2Output::Ros2Output(transport::Participant& participant, const Ros2Config& config, Outputs outputs)
    : config_(config), counters_(logger("ros2")) {
  if (outputs.odometry) {
    odometry_ = writer(participant, config.odometry_topic, ros2::kOdometryType, kMaxSmallBytes, ros2::sensor_data_qos());
    // tf2's own QoS: /tf reliable and volatile (100 deep), /tf_static reliable and transient local.
    transport::TopicQos tf_qos = ros2::default_qos();
    tf_qos.depth = 100;
    tf_ = writer(participant, config.tf_topic, ros2::kTfMessageType, kMaxSmallBytes, tf_qos);
    tf_static_ = writer(participant, config.tf_static_topic, ros2::kTfMessageType, kMaxSmallBytes,
                        ros2::transient_local_qos());
  }
  if (outputs.scan) scan_ = writer(participant, config.scan_topic, ros2::kPointCloud2Type, kMaxScanBytes, ros2::sensor_data_qos());
  if (outputs.map) map_ = writer(participant, config.map_topic, ros2::kPointCloud2Type, kMaxMapBytes, ros2::transient_local_qos());
  diagnostics_ = writer(participant, config.diagnostics_topic, ros2::kDiagnosticArrayType, kMaxSmallBytes,
                        ros2::default_qos());
}

void Ros2Output::odometry(const fuse_msgs::StateEstimate& s) {
  // At IMU rate on fuse-state's IMU path: nothing is built while no ROS 2 node listens.
  if (!odometry_ || (odometry_->matched_readers() == 0 && tf_->matched_readers() == 0)) return;
  ros2::Odometry m;
  m.t = s.t();
  m.frame = config_.world_frame;
  m.child_frame = config_.imu_frame;
  m.pose = from_pose(s.pose());
  for (std::size_t i = 0; i < 36; ++i) m.pose_covariance[i] = s.pose_covariance()[i];
  const Eigen::Matrix3d R_wi = m.pose.linear();
  const Eigen::Vector3d v_world(s.velocity().x(), s.velocity().y(), s.velocity().z());
  m.linear_velocity = R_wi.transpose() * v_world;  // ROS: the twist in child_frame
  m.angular_velocity = Eigen::Vector3d(s.angular_velocity().x(), s.angular_velocity().y(), s.angular_velocity().z());
  // Linear velocity covariance, rotated into the IMU frame; the angular rate's is not estimated.
  Eigen::Matrix3d P_world;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P_world(r, c) = s.velocity_covariance()[static_cast<std::size_t>(3 * r + c)];
  }
  const Eigen::Matrix3d P_imu = R_wi.transpose() * P_world * R_wi;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.twist_covariance[static_cast<std::size_t>(6 * r + c)] = P_imu(r, c);
  }
  const transport::Bytes odom = ros2::encode(m);
  const transport::Bytes tf = ros2::encode_tf({{m.t, config_.world_frame, config_.imu_frame, m.pose}});
  std::lock_guard<std::mutex> lock(mutex_);
  write(*odometry_, odom, "odometry");
  write(*tf_, tf, "tf");
}

void Ros2Output::static_transform(const Eigen::Isometry3d& T_imu_lidar) {
  if (!tf_static_) return;
  const transport::Bytes tf = ros2::encode_tf({{0.0, config_.imu_frame, config_.lidar_frame, T_imu_lidar}});
  std::lock_guard<std::mutex> lock(mutex_);
  write(*tf_static_, tf, "tf_static");
}

bool Ros2Output::scan_wanted() const { return scan_ && scan_->matched_readers() > 0; }

void Ros2Output::scan(double t, const std::vector<float>& xyz_world) {
  if (!scan_) return;
  const transport::Bytes cloud = ros2::encode_cloud(t, config_.world_frame, xyz_world);
  std::lock_guard<std::mutex> lock(mutex_);
  write(*scan_, cloud, "scan");
}

void Ros2Output::map(double t, const std::vector<float>& xyz_world) {
  if (!map_) return;
  const transport::Bytes cloud = ros2::encode_cloud(t, config_.world_frame, xyz_world);
  std::lock_guard<std::mutex> lock(mutex_);
  write(*map_, cloud, "map");
}

void Ros2Output::diagnostics(const fuse_msgs::Health& h) {
  const double t = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  ros2::DiagnosticStatus status;
  const std::string state = h.state().to_string();
  const std::string error = h.last_error().to_string();
  status.level = (state == "running" || state == "starting" || state == "stopping") ? 0 : state == "degraded" ? 1 : 2;
  status.name = h.service().to_string();
  status.message = state + (error.empty() ? std::string() : ": " + error);
  status.hardware_id = "fuse-slam";
  status.values.emplace_back("instance", std::to_string(h.instance()));
  status.values.emplace_back("uptime_s", std::to_string(h.uptime_s()));
  for (const fuse_msgs::Counter& c : h.counters()) status.values.emplace_back(c.name().to_string(), std::to_string(c.value()));
  const transport::Bytes array = ros2::encode_diagnostics(t, {status});
  std::lock_guard<std::mutex> lock(mutex_);
  write(*diagnostics_, array, "diagnostics");
}

void Ros2Output::write(transport::RawWriter& writer, const transport::Bytes& sample, const char* output) {
  if (writer.write(sample)) return;
  counters_.count(std::string("ros2_write_failed_") + output,
                  fmt::format("the DDS backend refused a ROS 2 {} sample ({} bytes): not published", output, sample.size()));
}

std::map<std::string, std::uint64_t> Ros2Output::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_.map();
}

void Ros2Output::attach(HealthReporter& health) {
  health.also_publish([this](const fuse_msgs::Health& h) { diagnostics(h); },
                      [this](HealthSnapshot& s) {
                        for (const auto& [name, value] : counters()) s.counters[name] += value;
                      });
}

}  // namespace fuse::service
