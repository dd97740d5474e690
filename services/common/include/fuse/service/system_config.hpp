// The configuration of the multi-process system: one YAML file, one typed section per module.
// Every service loads and validates the whole file (an unknown key or a bad value anywhere
// stops it, naming the key) and uses its own sections.
#pragma once

#include <string>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/estimation/estimator_config.hpp"
#include "fuse/map/map_server_core.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse::service {

struct IngestConfig {
  std::string mode = "lockstep";   ///< lockstep | realtime
  double rate = 1.0;               ///< realtime: playback speed factor
  double lockstep_timeout_s = 3.0; ///< lockstep: wait at most this long for a scan's correction
  double start_wait_s = 10.0;      ///< wait this long for fuse-state and fuse-update to appear
  /// Events read ahead of the schedule on a reader thread (io::PrefetchSource), so that a slow
  /// read (an MCAP chunk being decompressed) does not delay publishing. 400 = 2 s of 200 Hz IMU.
  int prefetch_events = 400;
  /// At the end (or on SIGTERM): wait at most this long for every matched reader to acknowledge
  /// what was published, so that a reader still catching up (a recorder that joined late) does
  /// not lose the last samples with the writers' history when the process exits.
  double flush_timeout_s = 5.0;
  /// Readers of the IMU and scan topics beyond fuse-state's and fuse-update's (a recorder) that
  /// must be matched before the replay starts; a reader matched later misses the first samples.
  int extra_readers = 0;
  /// What the IMU and scan writers hold for readers that join late or restart (transient-local
  /// depth): a restarted fuse-state re-propagates from the held IMU, a restarted fuse-update
  /// processes the held scans it has not answered. Sized for a 30 s outage: 60 s of 200 Hz IMU
  /// (~1.6 MB) and 30 s of 10 Hz scans (~150 MB for 20k-point scans; lower it for denser sensors).
  int held_imu = 12000;
  int held_scans = 300;
  /// Real-time replay: an event due longer ago than this is skipped (a restarted fuse-ingest
  /// joining the schedule: its downtime is a data gap); a later one is published at once.
  double max_lateness_s = 0.5;
  void load(ConfigNode& node);
};

struct StateServiceConfig {
  /// After a (re)start, wait for fuse-update to be discovered (its writer holds the last
  /// corrections, transient-local), at most this long, before falling back to static
  /// initialisation from the IMU.
  double recovery_wait_s = 3.0;
  double imu_buffer_s = 60.0;  ///< raw IMU kept for re-propagation after a recovered correction
  /// fuse-state's state history in seconds (at least estimator.history.length_s): corrections of
  /// scans that fuse-update held while fuse-state was down still land after a 30 s outage.
  double history_s = 40.0;
  /// fuse-state writes its newest corrected posterior here (atomically, at most every
  /// checkpoint_period_s) and recovers from it after a restart when no newer correction is held
  /// anywhere (fuse-update restarted with it). Empty: no checkpoint.
  std::string checkpoint_file;
  double checkpoint_period_s = 0.5;
  /// No LiDAR correction for this long (sensor time) while IMU samples arrive: the estimate is
  /// reported lost (IMU-only propagation drifts by metres within tens of seconds).
  double lost_after_s = 5.0;
  void load(ConfigNode& node);
};

struct UpdateServiceConfig {
  double history_deadline_s = 3.0;  ///< give up on a scan when fuse-state cannot cover it by then
  double map_sync_timeout_s = 3.0;  ///< at start-up: wait this long for the map server's chunks
  double resend_after_s = 1.0;      ///< re-send unacknowledged observations older than this
  std::size_t max_unacked = 2000;   ///< observations kept for re-sending (oldest given up, counted)
  /// Bytes of points kept for re-sending (oldest given up beyond it, counted): a map server that
  /// cannot write its disk for long must not exhaust fuse-update's memory.
  std::size_t max_unacked_bytes = std::size_t{256} << 20;
  /// Scans held (span of scan time) while fuse-state cannot answer (restarting, absent); beyond
  /// it the oldest is dropped and counted. Processed in order once it answers again.
  double max_backlog_s = 40.0;
  /// Scans waiting behind this many are compacted to the points the LiDAR step keeps.
  std::size_t compact_after = 5;
  void load(ConfigNode& node);
};

/// Scheduler slice requests per service (fuse/core/scheduling.hpp), applied to the service's
/// main thread once the config is read, before it starts any other thread, so every thread it
/// runs (the transport's receive and event threads among them) inherits them; only the
/// signal-waiting thread ("fuse-signals", started first) keeps the default. 0 keeps the
/// kernel's default slice (1.4 ms on two CPUs); 100..100000 us requests a shorter or longer one
/// (Linux 6.12 and later; older kernels ignore it, and the service logs so). fuse-state serves the query and history RPCs and
/// publishes odometry in short bursts: a 100 us slice lets those threads preempt a CPU-bound
/// update when they wake instead of waiting for its slice to end (docs/performance.md).
struct SchedulingConfig {
  int ingest_slice_us = 0;
  int state_slice_us = 100;
  int update_slice_us = 0;
  int map_slice_us = 0;
  /// CPU wake-up latency bound every service holds while it runs (cpu_latency.hpp), in us; -1
  /// holds none. 0 keeps idle CPUs polling: a scan no longer meets a sleeping CPU with cold
  /// caches, at the price of power.
  int cpu_latency_us = -1;
  /// The slice for a service by its process name ("fuse-state"); 0 for other processes (tools).
  int slice_us(const std::string& service) const;
  void load(ConfigNode& node);
};

struct HealthConfig {
  double period_s = 0.5;
  /// How long a heartbeat counts when telling two live instances of one service (same system
  /// name, same domain) from a restart: they are duplicates when each sent two heartbeats after
  /// the other's first one within this window (InstanceWatch). At least 2.5 health periods.
  double instance_window_s = 3.0;
  void load(ConfigNode& node);
};

/// fuse-viz, the live view (docs/architecture.md, "Live view"): a Foxglove WebSocket server.
struct VizConfig {
  std::string address = "127.0.0.1";  ///< listen address: localhost unless the operator opens it
  int port = 8765;                    ///< Foxglove's default; 0 takes any free port (logged)
  double max_client_queue_mb = 64.0;  ///< per client; a slow client loses its oldest samples beyond it
  /// Per client: samples that waited longer are dropped; a client that took none for this long is
  /// stalled and costs the producers nothing until it reads again.
  double max_client_backlog_s = 1.0;
  int max_clients = 16;
  double map_period_s = 1.0;          ///< the whole map is sent at most this often, when it changed
  double trajectory_period_s = 1.0;   ///< the trajectory so far, likewise
  std::size_t max_trajectory_poses = 20000;  ///< beyond it the trajectory is thinned to every other pose
  std::string world_frame = "world";  ///< frame names of the transform tree world -> imu -> lidar
  std::string imu_frame = "imu";
  std::string lidar_frame = "lidar";
  /// Niceness fuse-viz gives itself at start (0..19): a viewer yields the CPU to the estimator.
  int nice = 10;
  void load(ConfigNode& node);
};

/// ROS 2 output (docs/architecture.md, "ROS 2"): the services also publish ROS 2 types under
/// ROS 2 naming on the same DDS domain, for ROS 2 nodes to subscribe to without a bridge.
struct Ros2Config {
  bool enabled = false;
  std::string odometry_topic = "/fuse/odometry";  ///< nav_msgs/Odometry at IMU rate (fuse-state)
  std::string tf_topic = "/tf";                   ///< world -> imu at IMU rate (fuse-state)
  std::string tf_static_topic = "/tf_static";     ///< imu -> lidar, transient local (fuse-state)
  std::string scan_topic = "/fuse/cloud_registered";  ///< deskewed scan, world frame (fuse-update)
  std::string map_topic = "/fuse/map";            ///< the whole map, transient local (fuse-map)
  std::string diagnostics_topic = "/diagnostics"; ///< each service's health
  std::string world_frame = "world";
  std::string imu_frame = "imu";
  std::string lidar_frame = "lidar";
  double map_period_s = 2.0;  ///< the map at most this often, when it changed
  void load(ConfigNode& node);
};

struct SystemConfig {
  EstimatorConfig estimator;
  transport::TransportConfig transport;
  IngestConfig ingest;
  StateServiceConfig state;
  UpdateServiceConfig update;
  MapServerConfig map_server;
  SchedulingConfig scheduling;
  HealthConfig health;
  VizConfig viz;
  Ros2Config ros2;
  void load(ConfigNode& root);
};

/// Reads and validates a config file with "dotted.key=value" overrides; throws ConfigError.
SystemConfig load_system_config(const std::string& file, const std::vector<std::string>& overrides = {});

}  // namespace fuse::service
