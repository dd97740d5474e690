// fuse-state (DESIGN §2): owns the filter belief and the temporal state history.
//   in:  imu (propagate), update/correction (replace the entry at scan time, re-propagate)
//   out: state/odometry (every IMU sample), state/corrected (every LiDAR correction),
//        RPC query (planners), RPC history (fuse-update: the slice of history over a scan)
// Restart: the last correction arrives again (transient-local, held by fuse-update's writer)
// and so do the last seconds of IMU (held by fuse-ingest's writer): the service waits
// `state.recovery_wait_s` for a correction, restores the history from it and re-propagates the
// buffered IMU after it; without one it initialises statically from the IMU as on a first start.
#pragma once

#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "fuse/estimation/state_tracker.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::service {

class StateService {
 public:
  StateService(const SystemConfig& config, transport::Participant& participant, const std::string& trajectory_file);
  /// Runs until a stop is requested.
  void run();

 private:
  void on_imu(const fuse_msgs::ImuSample& msg);
  void on_correction(const fuse_msgs::Correction& msg);
  void on_query(const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep);
  void on_history(const fuse_msgs::HistoryRequest& req, fuse_msgs::HistoryReply& rep);
  /// Feeds one IMU sample to the tracker (lock held) and returns the odometry to publish.
  std::optional<fuse_msgs::StateEstimate> feed(const ImuSample& imu);
  void restore_from(const Posterior& post);
  void go_live();  ///< end of the recovery wait: buffered IMU goes to the tracker
  HealthSnapshot health();
  void malformed(const std::string& topic, const std::string& why);

  SystemConfig config_;
  std::mutex mutex_;  ///< guards everything below
  StateTracker tracker_;
  Counters counters_;
  std::deque<ImuSample> imu_buffer_;  ///< raw IMU of the last state.imu_buffer_s seconds
  bool live_ = false;                 ///< false during the recovery wait
  std::optional<Posterior> pending_recovery_;
  std::uint64_t odometry_sequence_ = 0;
  double last_applied_correction_t_ = -1.0;
  std::string last_error_;
  std::ofstream trajectory_;
  double trajectory_t_ = -1.0;  ///< newest pose in the trajectory file (kept across restarts)

  transport::Publisher<fuse_msgs::StateEstimate> odometry_;
  transport::Publisher<fuse_msgs::StateEstimate> corrected_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::ImuSample>> imu_sub_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> correction_sub_;
  std::unique_ptr<transport::RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>> query_server_;
  std::unique_ptr<transport::RpcServer<fuse_msgs::HistoryRequest, fuse_msgs::HistoryReply>> history_server_;
  std::unique_ptr<HealthReporter> health_;
};

}  // namespace fuse::service
