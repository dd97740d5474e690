// fuse-state (DESIGN §2): owns the filter belief and the temporal state history.
//   in:  imu (propagate), update/correction (replace the entry at scan time, re-propagate)
//   out: state/odometry (every IMU sample), state/corrected (every LiDAR correction),
//        RPC query (planners), RPC history (fuse-update: the slice of history over a scan)
//
// Restart (docs/architecture.md, "Restarts: nothing that can be kept is lost"): the newest of
// the posteriors still held anywhere is restored and the held IMU after it re-propagated:
//   - the corrections held by fuse-update's writer (transient-local), newest first;
//   - the service's own checkpoint (state.checkpoint_file), for when fuse-update restarted too;
//   - the IMU held by fuse-ingest's writer (ingest.held_imu, 60 s), so that an outage of up to
//     ~30 s is re-propagated from measurements instead of coasted.
// fuse-update holds the scans it could not process meanwhile and sends their corrections once
// this service answers again; the history is long enough (state.history_s) for them to land,
// and its re-propagation is lazy (StateHistory), so catching up costs one pass over the tail.
// Only with no posterior at all does it initialise statically from the IMU, as on a first start.
//
// Reported covariance: the filter's P is that of the pose relative to the map; the map frame's
// own uncertainty, accumulated from the corrections (Correction.map_drift, ScanReport::map_drift)
// and kept in the checkpoint, is added to the pose covariance of every estimate published.
//
// Tracking status, in every query reply and on health: tracking, relocalizing (restored from an
// old posterior and catching up, or fuse-update reports scans being re-localised), lost (no
// state while the sensor moves, fuse-update reports lost, or no LiDAR correction for
// state.lost_after_s of IMU).
//
// World frame (docs/architecture.md, "Starting anywhere in a saved map"): the history's frame
// against a saved map (WorldFrame: undecided, own, searching, confirming, localized) is set by
// fuse-update through its corrections; a correction one frame epoch ahead moves the history by
// its frame_change first. While searching or confirming, every reply says relocalizing with the
// search's candidate count, and trajectory lines are held (moved with the frame) until the
// location is confirmed.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "fuse/core/host_clock.hpp"
#include "fuse/service/ros2_output.hpp"
#include "fuse/estimation/state_tracker.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/state_checkpoint.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::service {

enum class Tracking { kTracking, kRelocalizing, kLost };
const char* to_string(Tracking tracking);

class StateService {
 public:
  StateService(const SystemConfig& config, transport::Participant& participant, const std::string& trajectory_file);
  ~StateService();
  /// Runs until a stop is requested.
  void run();

 private:
  void on_imu(const fuse_msgs::ImuSample& msg);
  void on_correction(const fuse_msgs::Correction& msg);
  void on_query(const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep);
  void on_history(const fuse_msgs::HistoryRequest& req, fuse_msgs::HistoryReply& rep);
  /// Feeds one IMU sample to the tracker (lock held) and returns the odometry to publish.
  std::optional<fuse_msgs::StateEstimate> feed(const ImuSample& imu);
  void restore_from(const Posterior& post, const std::string& source);
  /// The tracker's events (data gap, clock step): the prior is uncertain until a scan confirms it.
  void take_tracker_events();
  void go_live();  ///< end of the recovery wait: restore (or initialise) from what is held
  /// True while a restored history is being caught up (corrections far behind the newest IMU).
  bool catching_up() const;
  /// The status as of now (lock held); logs and counts changes.
  Tracking tracking();
  /// An estimate for planners: the state at q with the map frame's uncertainty added.
  fuse_msgs::StateEstimate estimate(const StateQuery& q, std::uint64_t sequence) const;
  void count_map_drift(const fuse_msgs::Correction& msg);
  /// Takes a correction's world frame (lock held): moves the history when it is one epoch ahead;
  /// false for a correction of an older frame (not to be applied).
  bool take_frame(const fuse_msgs::Correction& msg, const WorldFrame& frame);
  /// Writes a trajectory line, or holds it while the world frame is not the map's.
  void write_pose(double t, const NavState& x);
  HealthSnapshot health();
  void malformed(const std::string& topic, const std::string& why);

  SystemConfig config_;
  std::mutex mutex_;  ///< guards everything below
  StateTracker tracker_;
  Counters counters_;
  std::deque<ImuSample> imu_buffer_;  ///< raw IMU of the last state.imu_buffer_s seconds
  HostClockMap host_clock_;           ///< sensor clock to host clocks, from the IMU's arrivals
  bool live_ = false;                 ///< false during the recovery wait
  std::optional<Posterior> pending_recovery_;
  std::optional<Checkpoint> checkpoint_;  ///< read at start-up
  PoseCovariance map_drift_ = PoseCovariance::Zero();  ///< the map frame's accumulated uncertainty
  double map_drift_t_ = -1.0;                          ///< newest correction counted in it
  std::unique_ptr<CheckpointWriter> checkpoint_writer_;
  std::uint64_t odometry_sequence_ = 0;
  double last_applied_correction_t_ = -1.0;
  double newest_correction_t_ = -1.0;  ///< of any correction received (applied or not)
  double live_since_t_ = -1.0;  ///< sensor time from which the state is known (init or restore)
  /// Relocalizing until a scan is updated with TRACKING_OK after this: a restore, a data gap, a
  /// clock step (the tracker's events), a coast to a scan while the IMU is silent.
  bool unconfirmed_ = false;
  std::string unconfirmed_why_;
  std::chrono::steady_clock::time_point last_imu_arrival_{};  ///< wall clock of the newest IMU sample
  /// Wall clock of the restore, and whether an IMU sample after the restored posterior has come
  /// since: until one has, a scan ahead of the IMU waits kRestartImuWaitS, not kImuSilenceS.
  std::chrono::steady_clock::time_point restored_at_{};
  bool imu_since_restore_ = true;
  double silent_wait_t_ = -1.0;  ///< the scan end a history request waits on, IMU silent
  std::chrono::steady_clock::time_point silent_wait_since_{};  ///< since when it was first asked for
  fuse_msgs::TrackingState update_tracking_ = fuse_msgs::TRACKING_OK;  ///< of the newest correction
  Tracking tracking_ = Tracking::kTracking;
  std::string tracking_reason_;
  std::string last_error_;
  std::ofstream trajectory_;
  double trajectory_t_ = -1.0;  ///< newest pose in the trajectory file (kept across restarts)
  WorldFrame frame_;                          ///< the history's frame against a saved map
  std::optional<WorldFrame> pending_frame_;   ///< pending_recovery_'s
  std::uint32_t candidates_ = 0;              ///< of the newest search (while searching)
  std::string localization_;                  ///< the search's state in words
  std::vector<std::pair<double, Eigen::Isometry3d>> held_poses_;  ///< T_world_imu, until the frame is the map's

  transport::Publisher<fuse_msgs::StateEstimate> odometry_;
  std::unique_ptr<Ros2Output> ros2_;  ///< ros2.enabled: odometry and transforms for ROS 2 as well
  transport::Publisher<fuse_msgs::StateEstimate> corrected_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::ImuSample>> imu_sub_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> correction_sub_;
  std::unique_ptr<transport::RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>> query_server_;
  std::unique_ptr<transport::RpcServer<fuse_msgs::HistoryRequest, fuse_msgs::HistoryReply>> history_server_;
  std::unique_ptr<HealthReporter> health_;
  /// health_ once made (IMU samples may arrive before): it tells whether two fuse-ingest are alive.
  std::atomic<const HealthReporter*> instances_{nullptr};
};

}  // namespace fuse::service
