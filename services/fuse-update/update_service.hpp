// fuse-update (DESIGN §2): owns the local map replica and the estimator backend.
//   in:  lidar/scan, map/chunk + map/status (replica sync, mode, acknowledgements)
//   out: update/correction (one per scan: posterior at scan end with the full covariance, or
//        "prior only" / "skipped"), map/observation (world-frame points of each processed scan)
//   uses RPC history (fuse-state) for the slice of state history over each scan.
// One scan: ask fuse-state for the history over [t_start, t_end] (it answers once IMU covers
// t_end), run the LiDAR step (LidarUpdater: deskew, associate, screen, update) on that slice,
// publish the posterior, offer the points to the map.
// The replica is written through: the policy inserts each scan's points locally at once, as in
// the single-process estimator (the next scan must see them with no round trip); the map
// server's chunks build the replica at start-up and after the map server replaces its map
// (a new epoch). Observations carry (session, sequence); those the map server has not yet
// acknowledged on map/status are re-sent, within bounds (unacked_observations.hpp).
// While fuse-state cannot answer (restarting, absent) scans are held (ScanBacklog, bounded) and
// processed in order once it can: a restart costs latency, not poses. Each history slice is
// brought up to this instance's own newest posterior when fuse-state has not applied it yet, so
// the scans of a backlog chain exactly as in the single-process estimator.
// World frame against a saved map (FrameLocalizer): a session that starts on a saved map searches
// it for its place, in its own frame, before it tracks and extends the map in the map's frame;
// RPC update/set_pose gives it a pose to search around (served here, where map and search are).
#pragma once

#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/tracking_monitor.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/ros2_output.hpp"
#include "fuse/service/scan_backlog.hpp"
#include "fuse/service/system_config.hpp"
#include "frame_localizer.hpp"
#include "fuse/transport/rpc.hpp"
#include "unacked_observations.hpp"

namespace fuse::service {

class UpdateService {
 public:
  UpdateService(const SystemConfig& config, transport::Participant& participant);
  ~UpdateService();
  /// Runs until a stop is requested.
  void run();

 private:
  void on_scan(const std::uint8_t* data, std::size_t size);
  void on_chunk(const fuse_msgs::MapChunk& msg);
  void on_status(const fuse_msgs::MapStatus& msg);
  void sync_map(double timeout_s);
  /// Every chunk of the server's current epoch has arrived (mutex_ held).
  bool chunks_complete() const;
  /// kHold: fuse-state cannot answer now; the scan goes back to the backlog's front.
  enum class Outcome { kDone, kHold };
  Outcome process(LidarScan& scan);
  /// Asks fuse-state for the history slice: kOk, kSkip (counted: the scan cannot be processed)
  /// or kHold (fuse-state is recovering or absent: ask again later).
  enum class Fetch { kOk, kSkip, kHold };
  Fetch fetch_history(const LidarScan& scan, StateHistory& out);
  /// The slice lacks this instance's newest posterior (fuse-state has not applied it yet, or
  /// restarted from an older one): apply it there, as fuse-state will (StateHistory::correct).
  void bring_up_to_date(StateHistory& history, double slice_last_correction_t);
  void publish_skipped(const LidarScan& scan);
  void offer_to_map(double t);
  /// The processed scan's deskewed points in the world frame on update/world_scan, for viewers
  /// (fuse-viz, fuse-record); nothing is built while no reader is matched.
  void publish_world_scan(const LidarScan& scan);
  /// Most points one WorldScan carries (the bound of WorldScan.points in fuse_msgs.idl).
  static constexpr std::size_t kMaxWorldScanPoints = 262144;
  void resend_unacked(bool all);
  /// RPC update/set_pose: waits (its own thread) for the verdict, at most the request's wait_s.
  void on_set_pose(const fuse_msgs::SetPoseRequest& req, fuse_msgs::SetPoseReply& rep);
  /// The saved map's mode and gravity as the map server says (mutex_ held).
  FrameLocalizer::MapContext map_context() const;
  /// After a scan: the localization's event logged and counted, set-pose verdicts handed over.
  void after_localization_step(const LocalizationEvent& e);
  HealthSnapshot health();

  SystemConfig config_;
  const std::uint64_t session_;
  LidarUpdater updater_;  ///< worker thread only
  TrackingMonitor monitor_;  ///< worker thread only: tracking / relocalizing / lost, sent in each Correction
  double last_scan_t_ = -1.0;
  std::optional<Posterior> last_posterior_;  ///< worker thread only: the newest SCAN_UPDATED published
  std::uint64_t observation_sequence_ = 0;
  FrameLocalizer frame_;  ///< worker thread only
  WorldFrame slice_frame_;  ///< worker thread only: of the last history slice fetched
  double slice_last_correction_t_ = 0.0;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();  ///< worker thread only: at the last scan, world frame

  std::mutex mutex_;  ///< guards what the DDS callbacks share with the worker
  std::condition_variable cv_;
  ScanBacklog backlog_;  ///< decoded, not yet checked (process() does)
  bool holding_ = false;  ///< the backlog waits for fuse-state
  std::map<std::uint64_t, fuse_msgs::MapChunk> chunks_;  ///< newest chunk of each key, kept while (re)syncing
  bool have_status_ = false;
  fuse_msgs::MapStatus status_;
  std::uint64_t replica_epoch_ = 0;
  std::string replica_mode_;
  /// The replica holds every chunk of the map server's epoch. False when it was built without the
  /// server (down at start: it started empty) or before every chunk arrived: it is rebuilt as soon
  /// as the server's chunks are all here, or a replica seeded from this instance's own scans
  /// would stand in for the map for good (an odometry that drifts, and bends what it offers).
  bool replica_complete_ = false;
  UnackedObservations unacked_;
  Counters counters_;
  std::map<std::string, std::uint64_t> updater_counts_;  ///< copied from the worker after each scan
  std::string last_error_;
  std::string state_ = "starting";
  struct PoseRequest {
    std::uint64_t id;
    InitialPose pose;
    double t;
  };
  std::deque<PoseRequest> pose_requests_;  ///< set-pose requests for the worker
  std::map<std::uint64_t, PoseVerdict> pose_verdicts_;  ///< what the worker decided (pending ones too)
  std::vector<std::uint64_t> pose_checks_;  ///< worker thread only: requests whose verdict is pending
  std::uint64_t next_pose_id_ = 0;
  std::condition_variable verdict_cv_;
  std::string localization_;  ///< the frame's state in words, for health
  bool relocalizing_ = false;  ///< searching the saved map or confirming a location

  transport::Publisher<fuse_msgs::Correction> corrections_;
  transport::Publisher<fuse_msgs::MapObservation> observations_;
  transport::Publisher<fuse_msgs::WorldScan> world_scans_;
  std::unique_ptr<Ros2Output> ros2_;  ///< ros2.enabled: the deskewed scan for ROS 2 as well
  transport::RpcClient<fuse_msgs::HistoryRequest, fuse_msgs::HistoryReply> history_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapChunk>> chunk_sub_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapStatus>> status_sub_;
  std::unique_ptr<transport::RawSubscriber<fuse_msgs::LidarScan>> scan_sub_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> corrected_sub_;
  double corrected_t_ = -1.0;  ///< newest state/corrected time: older scans were answered before
  std::unique_ptr<transport::RpcServer<fuse_msgs::SetPoseRequest, fuse_msgs::SetPoseReply>> set_pose_server_;
  std::unique_ptr<HealthReporter> health_;
};

}  // namespace fuse::service
