// FUSE's wire types as Foxglove messages (fuse/service/foxglove_view.hpp).
#include "fuse/service/foxglove_view.hpp"

#include <algorithm>

#include "fuse/foxglove/messages.hpp"
#include "fuse/service/convert.hpp"

namespace fuse::service {
namespace {

foxglove::Channel json_channel(const std::string& topic, const foxglove::JsonSchema& schema, bool latched = false) {
  return foxglove::Channel{topic, "json", schema.name, schema.text, "jsonschema", latched};
}

std::vector<float> xyz_of(const std::vector<fuse_msgs::Point3f>& points) {
  std::vector<float> xyz;
  xyz.reserve(3 * points.size());
  for (const fuse_msgs::Point3f& p : points) {
    xyz.push_back(p.x());
    xyz.push_back(p.y());
    xyz.push_back(p.z());
  }
  return xyz;
}

}  // namespace

FoxgloveView::FoxgloveView(const VizConfig& config, const Eigen::Isometry3d& T_imu_lidar)
    : config_(config), T_imu_lidar_(T_imu_lidar) {}

std::vector<foxglove::Channel> FoxgloveView::channels() {
  using namespace foxglove;
  // In FoxgloveTopic order.
  return {json_channel(topics::kPose, pose_in_frame_schema()),
          json_channel(topics::kPoseScan, pose_in_frame_schema()),
          json_channel(topics::kTf, frame_transforms_schema()),
          json_channel(topics::kTfStatic, frame_transforms_schema(), true),
          json_channel(topics::kScan, point_cloud_schema()),
          json_channel(topics::kMap, point_cloud_schema(), true),
          json_channel(topics::kTrajectory, poses_in_frame_schema(), true),
          json_channel(topics::kHealth, health_schema())};
}

std::vector<FoxgloveMessage> FoxgloveView::odometry(const fuse_msgs::StateEstimate& s, bool pose_wanted,
                                                    bool tf_wanted) {
  const Eigen::Isometry3d T_world_imu = from_pose(s.pose());
  latest_t_ = std::max(latest_t_, s.t());
  std::vector<FoxgloveMessage> out;
  if (pose_wanted) {
    out.push_back({FoxgloveTopic::kPose, s.t(), foxglove::pose_in_frame_json(s.t(), config_.world_frame, T_world_imu)});
  }
  if (tf_wanted) {
    out.push_back({FoxgloveTopic::kTf, s.t(),
                   foxglove::frame_transforms_json({{s.t(), config_.world_frame, config_.imu_frame, T_world_imu}})});
  }
  return out;
}

FoxgloveMessage FoxgloveView::corrected(const fuse_msgs::StateEstimate& s) {
  const Eigen::Isometry3d T_world_imu = from_pose(s.pose());
  latest_t_ = std::max(latest_t_, s.t());
  if (trajectory_t_.empty() || s.t() > trajectory_t_.back()) {  // a repeat after a restart is not a new pose
    trajectory_.push_back(T_world_imu);
    trajectory_t_.push_back(s.t());
    trajectory_changed_ = true;
    if (trajectory_.size() > config_.max_trajectory_poses) {
      // Bounded: every other pose is kept, the newest always.
      std::size_t kept = 0;
      for (std::size_t i = trajectory_.size() % 2 == 0 ? 1 : 0; i < trajectory_.size(); i += 2, ++kept) {
        trajectory_[kept] = trajectory_[i];
        trajectory_t_[kept] = trajectory_t_[i];
      }
      trajectory_.resize(kept);
      trajectory_t_.resize(kept);
      ++thinned_;
    }
  }
  return {FoxgloveTopic::kPoseScan, s.t(), foxglove::pose_in_frame_json(s.t(), config_.world_frame, T_world_imu)};
}

FoxgloveMessage FoxgloveView::world_scan(const fuse_msgs::WorldScan& s) {
  latest_t_ = std::max(latest_t_, s.t());
  return {FoxgloveTopic::kScan, s.t(), foxglove::point_cloud_json(s.t(), config_.world_frame, xyz_of(s.points()))};
}

void FoxgloveView::chunk(const fuse_msgs::MapChunk& c) {
  Chunk& chunk = chunks_[c.key()];
  // A chunk of an older map (epoch) or an older revision of this one changes nothing.
  if (std::make_pair(c.epoch(), c.revision()) < std::make_pair(chunk.epoch, chunk.revision)) return;
  chunk.epoch = c.epoch();
  chunk.revision = c.revision();
  chunk.xyz = xyz_of(c.points());
  map_changed_ = true;
}

FoxgloveMessage FoxgloveView::health(const fuse_msgs::Health& h) {
  foxglove::HealthView view;
  view.t = latest_t_;
  view.service = h.service();
  view.instance = h.instance();
  view.state = h.state();
  view.uptime_s = h.uptime_s();
  view.last_error = h.last_error();
  for (const fuse_msgs::Counter& c : h.counters()) view.counters[c.name().to_string()] = c.value();
  return {FoxgloveTopic::kHealth, view.t, foxglove::health_json(view)};
}

FoxgloveMessage FoxgloveView::static_transforms(double t) const {
  return {FoxgloveTopic::kTfStatic, t,
          foxglove::frame_transforms_json({{t, config_.imu_frame, config_.lidar_frame, T_imu_lidar_}})};
}

std::optional<FoxgloveMessage> FoxgloveView::map_if_changed() {
  if (!map_changed_) return std::nullopt;
  map_changed_ = false;
  std::vector<float> xyz;
  xyz.reserve(3 * map_points());
  for (const auto& [key, chunk] : chunks_) xyz.insert(xyz.end(), chunk.xyz.begin(), chunk.xyz.end());
  return FoxgloveMessage{FoxgloveTopic::kMap, latest_t_, foxglove::point_cloud_json(latest_t_, config_.world_frame, xyz)};
}

std::optional<FoxgloveMessage> FoxgloveView::trajectory_if_changed() {
  if (!trajectory_changed_) return std::nullopt;
  trajectory_changed_ = false;
  const double t = trajectory_t_.back();
  return FoxgloveMessage{FoxgloveTopic::kTrajectory, t,
                         foxglove::poses_in_frame_json(t, config_.world_frame, trajectory_)};
}

std::uint64_t FoxgloveView::map_points() const {
  std::uint64_t n = 0;
  for (const auto& [key, chunk] : chunks_) n += chunk.xyz.size() / 3;
  return n;
}

}  // namespace fuse::service
