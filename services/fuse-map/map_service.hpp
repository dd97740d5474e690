// fuse-map's transport side (DESIGN §2): MapServerCore behind DDS.
//
//   map/observation -> queue -> ONE worker thread: check, apply (journal first), then publish the
//                      changed chunks (whole contents) and a MapStatus for that session
//   rpc map/control -> the same queue, the RPC thread waits for the worker: the core (not
//                      thread-safe) only ever sees the worker
//   map/chunk       <- every chunk at start-up and after a load (with an empty chunk of the new
//                      epoch for every key the loaded map no longer has), changed chunks after
//                      each applied observation
//   map/status      <- at start-up (every recent session's acknowledged sequence, as loaded),
//                      after every observation (duplicates are acknowledged again), after
//                      pending observations were journaled, and after a mode change or a load
//
// The DDS callbacks only enqueue. When the worker falls behind, observations beyond the queue's
// bound are dropped and counted: they stay unacknowledged and their sender re-sends them.
// When the journal cannot be written (full or read-only disk, an unwritable directory at
// start-up) the core keeps observations pending and acknowledges nothing new; the service is
// then "degraded" (health, map/status last_error, map/control stats say why), and the worker
// calls the core's retry() every map_server.retry_interval_s until it is running again.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "fuse/core/counters.hpp"
#include "fuse/map/map_server_core.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/ros2_output.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::map_service {

/// The observation's refusal counter ("refused_session_zero", ...), or nullptr when it is usable.
/// Points that are not finite do not refuse an observation: they are dropped and counted.
const char* refusal_reason(const fuse_msgs::MapObservation& observation);

class MapService {
 public:
  /// Observations waiting for the worker beyond this are dropped (the sender re-sends them).
  static constexpr std::size_t kMaxQueuedObservations = 128;
  /// Most points one published chunk can carry (the bound of MapChunk.points in fuse_msgs.idl).
  static constexpr std::size_t kMaxChunkPoints = 1048576;

  /// Loads the map directory (damage is logged and kept for health), publishes every chunk and a
  /// status, then starts serving; degraded when the directory cannot be written. Throws
  /// MapDirectoryLocked when another fuse-map holds the directory, MapStorageError when its
  /// files cannot be read, ConfigError on a bad config.
  /// With `ros2`, the whole map also goes out as a ROS 2 PointCloud2 when it changed, at most
  /// every `ros2_period_s`.
  MapService(const MapServerConfig& config, transport::Participant& participant,
             std::shared_ptr<service::Ros2Output> ros2 = nullptr, double ros2_period_s = 0.0);
  ~MapService();
  MapService(const MapService&) = delete;
  MapService& operator=(const MapService&) = delete;

  /// Stops taking observations and requests, then stops the worker (queued observations are
  /// dropped unacknowledged). Idempotent.
  void stop();

  /// State, counters and last error for the heartbeat (any thread).
  service::HealthSnapshot health() const;

  /// Seconds since the worker last showed progress (it does at least every kWorkerBeat while
  /// idle, and after each job): the main loop pings the service manager's watchdog only while
  /// this stays below kWorkerStuckS, so a worker stuck in one job gets the service restarted.
  double worker_silence_s() const;
  static constexpr std::chrono::milliseconds kWorkerBeat{250};
  static constexpr double kWorkerStuckS = 5.0;

 private:
  using ControlServer = transport::RpcServer<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply>;

  struct Job {
    std::unique_ptr<fuse_msgs::MapObservation> observation;  ///< set: an observation
    std::function<void()> control;                           ///< otherwise: a control request
  };

  // DDS threads: enqueue only.
  void on_observation(const fuse_msgs::MapObservation& observation);
  void on_malformed(const std::string& reason);
  void on_control(const fuse_msgs::MapControlRequest& request, fuse_msgs::MapControlReply& reply);

  // Worker thread: everything that touches the core.
  void run();
  void handle_observation(const fuse_msgs::MapObservation& observation);
  void handle_control(const fuse_msgs::MapControlRequest& request, const std::string& caller,
                      fuse_msgs::MapControlReply& reply);
  /// The saved map `name` resolves to (map_names.hpp), or nullopt after refusing the request:
  /// counted, and the reply's error is `refusal` and what a name must be.
  std::optional<std::filesystem::path> saved_map(const std::string& name, const std::string& refusal,
                                                 fuse_msgs::MapControlReply& reply);
  void save_map(const std::string& name, fuse_msgs::MapControlReply& reply);
  void load_map(const std::string& name, bool other_system, fuse_msgs::MapControlReply& reply);
  void publish_chunk(const PointChunk& chunk);
  void publish_all_chunks();
  /// The whole map on ROS 2 when it changed and its period has passed (worker thread).
  void publish_ros2_map_if_due();
  void publish_status();
  /// While degraded, calls the core's retry() when it is due; publishes what it journaled.
  void retry_if_due();
  /// Copies the core's state and counters into health (state running | degraded).
  void refresh_stats();

  /// Adds n to a health counter; returns its new value.
  std::uint64_t count(const std::string& counter, std::uint64_t n = 1);
  /// Counts one occurrence of a problem and logs message, rate-limited per counter
  /// (fuse::Counters: a flood of bad input or errors stays readable, with counts).
  void report(const std::string& counter, const std::string& message);
  void set_error(const std::string& error);

  std::unique_ptr<MapServerCore> core_;  ///< worker thread only (and the constructor)
  std::shared_ptr<service::Ros2Output> ros2_;
  std::chrono::duration<double> ros2_period_{0.0};
  bool ros2_map_changed_ = false;                           ///< worker thread
  std::chrono::steady_clock::time_point ros2_next_map_{};  ///< worker thread
  double last_observation_t_ = 0.0;                        ///< worker thread: the ROS 2 map's stamp
  std::filesystem::path saved_maps_;     ///< where save NAME and load NAME resolve (map_names.hpp)
  /// Worker thread: when the next retry() is due while degraded (unset: not degraded).
  std::optional<std::chrono::steady_clock::time_point> retry_at_;

  transport::Publisher<fuse_msgs::MapChunk> chunks_;
  transport::Publisher<fuse_msgs::MapStatus> status_;

  mutable std::mutex health_mutex_;
  std::map<std::string, std::uint64_t> counters_;
  Counters reported_;  ///< counters whose occurrences are logged (rate-limited)
  std::string state_ = "starting";
  std::string last_error_;
  std::string degraded_reason_;  ///< the core's, empty when running

  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Job> queue_;
  std::size_t queued_observations_ = 0;
  bool stop_ = false;
  std::thread worker_;
  std::atomic<std::int64_t> worker_alive_ns_{0};  ///< steady clock of the worker's last beat

  std::unique_ptr<transport::Subscriber<fuse_msgs::MapObservation>> observations_;
  std::unique_ptr<ControlServer> control_;
};

}  // namespace fuse::map_service
