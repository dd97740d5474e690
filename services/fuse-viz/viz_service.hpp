// fuse-viz's transport side: the system's topics read from DDS and served to Foxglove clients
// (fuse/foxglove/server.hpp) in the schemas Foxglove's 3D panel draws.
//
//   state/odometry    -> /fuse/pose (foxglove.PoseInFrame, IMU rate), /tf (world -> imu)
//   state/corrected   -> /fuse/pose_scan (scan rate), /fuse/trajectory (the poses so far, latched)
//   update/world_scan -> /fuse/scan (foxglove.PointCloud, the deskewed scan in the world frame)
//   map/chunk         -> /fuse/map (foxglove.PointCloud of the whole map, latched, at most every
//                        viz.map_period_s when it changed: a late client gets it at once)
//   health            -> /fuse/health (fuse.Health)
//   (config)          -> /tf_static (imu -> lidar, latched)
//
// Every DDS callback encodes and hands the message to the server, which queues it per client
// (bounded, the oldest dropped and counted): a slow client never holds up a DDS thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "fuse/foxglove/server.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::viz {

/// The channels fuse-viz serves, in channel-id order (id = index + 1).
enum class VizChannel : foxglove::ChannelId {
  kPose = 1,
  kPoseScan,
  kTf,
  kTfStatic,
  kScan,
  kMap,
  kTrajectory,
  kHealth,
};

/// The advertised channels (topics, schemas), for the server and the documentation test.
std::vector<foxglove::Channel> viz_channels();

class VizService {
 public:
  /// Starts the Foxglove server and the DDS readers. Throws std::runtime_error when the address
  /// cannot be bound.
  VizService(const service::SystemConfig& config, transport::Participant& participant);
  ~VizService();
  VizService(const VizService&) = delete;
  VizService& operator=(const VizService&) = delete;

  std::uint16_t port() const { return server_.port(); }
  service::HealthSnapshot health() const;
  void stop();

 private:
  struct Chunk {
    std::uint64_t epoch = 0;
    std::uint64_t revision = 0;
    std::vector<float> xyz;
  };

  void on_odometry(const fuse_msgs::StateEstimate& s);
  void on_corrected(const fuse_msgs::StateEstimate& s);
  void on_world_scan(const fuse_msgs::WorldScan& s);
  void on_chunk(const fuse_msgs::MapChunk& c);
  void on_health(const fuse_msgs::Health& h);
  void malformed(const std::string& topic, const std::string& reason);
  /// Publishes the map and the trajectory when changed, at their periods (own thread).
  void run_periodic();
  void publish(VizChannel channel, double t, std::string payload);

  service::VizConfig config_;
  Eigen::Isometry3d T_imu_lidar_;
  foxglove::Server server_;
  std::atomic<double> latest_t_{0.0};  ///< newest sensor time seen: the time of health and map messages

  mutable std::mutex mutex_;
  std::map<std::uint64_t, Chunk> chunks_;           // by key
  bool map_changed_ = false;
  std::vector<Eigen::Isometry3d> trajectory_;       // scan-rate poses, thinned beyond the bound
  std::vector<double> trajectory_t_;
  bool trajectory_changed_ = false;
  std::map<std::string, std::uint64_t> counters_;
  std::string last_error_;

  bool stopping_ = false;
  std::condition_variable wake_;
  std::thread periodic_;

  // Readers last: they call into everything above.
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> odometry_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> corrected_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::WorldScan>> world_scans_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapChunk>> chunks_reader_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> health_;
};

}  // namespace fuse::viz
