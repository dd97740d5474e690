// The system's topics as Foxglove draws them (docs/architecture.md, "Live view"): one mapping from
// FUSE's wire types to the Foxglove channels, shared by fuse-viz (live, over WebSocket) and
// fuse-record (into the recording, beside the project's own channels), so that both show the
// same thing under the same names.
//
//   state/odometry    -> /fuse/pose (foxglove.PoseInFrame, IMU rate), /tf (world -> imu)
//   state/corrected   -> /fuse/pose_scan (scan rate), and the trajectory
//   update/world_scan -> /fuse/scan (foxglove.PointCloud, deskewed, world frame)
//   map/chunk         -> the map, sent whole as /fuse/map when changed
//   health            -> /fuse/health (fuse.Health)
//   (config)          -> /tf_static (imu -> lidar)
//
// Not thread-safe: the caller serialises the calls.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fuse/foxglove/server.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse_msgs.h"

namespace fuse::service {

/// The channels, in channel-id order (id = the enum's value; Server::ChannelId).
enum class FoxgloveTopic : foxglove::ChannelId {
  kPose = 1,
  kPoseScan,
  kTf,
  kTfStatic,
  kScan,
  kMap,
  kTrajectory,
  kHealth,
};

struct FoxgloveMessage {
  FoxgloveTopic topic;
  double t = 0.0;       ///< the message's sensor time (s): its log time
  std::string payload;  ///< JSON
};

class FoxgloveView {
 public:
  /// Frame names and the trajectory's bound from `config`; T_imu_lidar for /tf_static.
  FoxgloveView(const VizConfig& config, const Eigen::Isometry3d& T_imu_lidar);

  /// Every channel (topic, encoding json, schema name and JSON Schema); latched: /tf_static,
  /// /fuse/map, /fuse/trajectory.
  static std::vector<foxglove::Channel> channels();

  /// /fuse/pose and /tf from an odometry sample (only those `wanted`). Throws InvalidSample.
  std::vector<FoxgloveMessage> odometry(const fuse_msgs::StateEstimate& s, bool pose_wanted = true,
                                        bool tf_wanted = true);
  /// /fuse/pose_scan; the pose joins the trajectory. Throws InvalidSample.
  FoxgloveMessage corrected(const fuse_msgs::StateEstimate& s);
  /// /fuse/scan: the deskewed scan in the world frame.
  FoxgloveMessage world_scan(const fuse_msgs::WorldScan& s);
  /// A map chunk replaces its older revision (or a chunk of an older map).
  void chunk(const fuse_msgs::MapChunk& c);
  /// /fuse/health, at the newest sensor time seen.
  FoxgloveMessage health(const fuse_msgs::Health& h);
  /// /tf_static (imu -> lidar), at time t.
  FoxgloveMessage static_transforms(double t) const;
  /// /fuse/map, the whole map, when a chunk changed since the last call.
  std::optional<FoxgloveMessage> map_if_changed();
  /// /fuse/trajectory, the scan-rate poses so far, when one was added since the last call.
  std::optional<FoxgloveMessage> trajectory_if_changed();

  /// Newest sensor time seen (odometry, scans).
  double latest_t() const { return latest_t_; }
  std::uint64_t map_points() const;
  /// Times the trajectory was thinned to every other pose (max_trajectory_poses).
  std::uint64_t trajectory_thinned() const { return thinned_; }

 private:
  struct Chunk {
    std::uint64_t epoch = 0;
    std::uint64_t revision = 0;
    std::vector<float> xyz;
  };
  VizConfig config_;
  Eigen::Isometry3d T_imu_lidar_;
  double latest_t_ = 0.0;
  std::map<std::uint64_t, Chunk> chunks_;  // by key
  bool map_changed_ = false;
  std::vector<Eigen::Isometry3d> trajectory_;
  std::vector<double> trajectory_t_;
  bool trajectory_changed_ = false;
  std::uint64_t thinned_ = 0;
};

}  // namespace fuse::service
