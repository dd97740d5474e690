#include "fuse/service/system_config.hpp"

#include "fuse/transport/ros2.hpp"

#include <cmath>

#include "fuse/core/cpu_latency.hpp"
#include "fuse/core/scheduling.hpp"

namespace fuse::service {

namespace {
/// Smallest update.max_unacked_bytes: several observations of the largest size (3 MiB).
constexpr std::size_t kMinUnackedBytes = std::size_t{16} << 20;
}  // namespace

void IngestConfig::load(ConfigNode& node) {
  node.get("mode", mode).get("rate", rate).get("lockstep_timeout_s", lockstep_timeout_s).get("start_wait_s", start_wait_s)
      .get("prefetch_events", prefetch_events).get("flush_timeout_s", flush_timeout_s)
      .get("extra_readers", extra_readers).get("held_imu", held_imu).get("held_scans", held_scans)
      .get("max_lateness_s", max_lateness_s);
  node.check(mode == "lockstep" || mode == "realtime", "mode", "must be lockstep or realtime");
  node.check(std::isfinite(rate) && rate > 0.0 && rate <= 100.0, "rate", "must be in (0, 100]");
  node.check(lockstep_timeout_s > 0.0 && lockstep_timeout_s <= 60.0, "lockstep_timeout_s", "must be in (0, 60] s");
  node.check(start_wait_s >= 0.0 && start_wait_s <= 120.0, "start_wait_s", "must be in [0, 120] s");
  node.check(prefetch_events >= 1 && prefetch_events <= 100000, "prefetch_events", "must be in [1, 100000]");
  node.check(flush_timeout_s >= 0.0 && flush_timeout_s <= 60.0, "flush_timeout_s", "must be in [0, 60] s");
  node.check(extra_readers >= 0 && extra_readers <= 64, "extra_readers", "must be in [0, 64]");
  node.check(held_imu >= 1 && held_imu <= 200000, "held_imu", "must be in [1, 200000] samples");
  node.check(held_scans >= 1 && held_scans <= 10000, "held_scans", "must be in [1, 10000] scans");
  node.check(std::isfinite(max_lateness_s) && max_lateness_s >= 0.0 && max_lateness_s <= 60.0, "max_lateness_s",
             "must be in [0, 60] s");
  node.finish();
}

void StateServiceConfig::load(ConfigNode& node) {
  node.get("recovery_wait_s", recovery_wait_s).get("imu_buffer_s", imu_buffer_s).get("history_s", history_s);
  node.get("checkpoint_file", checkpoint_file).get("checkpoint_period_s", checkpoint_period_s);
  node.get("lost_after_s", lost_after_s);
  node.check(recovery_wait_s >= 0.0 && recovery_wait_s <= 30.0, "recovery_wait_s", "must be in [0, 30] s");
  node.check(imu_buffer_s >= 1.0 && imu_buffer_s <= 600.0, "imu_buffer_s", "must be in [1, 600] s");
  node.check(std::isfinite(history_s) && history_s >= 0.5 && history_s <= 600.0, "history_s", "must be in [0.5, 600] s");
  node.check(std::isfinite(checkpoint_period_s) && checkpoint_period_s >= 0.01 && checkpoint_period_s <= 600.0,
             "checkpoint_period_s", "must be in [0.01, 600] s");
  node.check(std::isfinite(lost_after_s) && lost_after_s > 0.0 && lost_after_s <= 600.0, "lost_after_s",
             "must be in (0, 600] s");
  node.finish();
}

void UpdateServiceConfig::load(ConfigNode& node) {
  node.get("history_deadline_s", history_deadline_s).get("map_sync_timeout_s", map_sync_timeout_s);
  node.get("resend_after_s", resend_after_s).get("max_unacked", max_unacked);
  node.get("max_unacked_bytes", max_unacked_bytes);
  node.get("max_backlog_s", max_backlog_s).get("compact_after", compact_after);
  node.check(std::isfinite(max_backlog_s) && max_backlog_s >= 1.0 && max_backlog_s <= 600.0, "max_backlog_s",
             "must be in [1, 600] s");
  node.check(compact_after <= 10000, "compact_after", "must be at most 10000");
  node.check(history_deadline_s > 0.0 && history_deadline_s <= 30.0, "history_deadline_s", "must be in (0, 30] s");
  node.check(map_sync_timeout_s >= 0.0 && map_sync_timeout_s <= 60.0, "map_sync_timeout_s", "must be in [0, 60] s");
  node.check(resend_after_s > 0.0 && resend_after_s <= 60.0, "resend_after_s", "must be in (0, 60] s");
  node.check(max_unacked >= 10, "max_unacked", "must be at least 10");
  node.check(max_unacked_bytes >= kMinUnackedBytes, "max_unacked_bytes",
             "must be at least " + std::to_string(kMinUnackedBytes) + " bytes (a few of the largest observations)");
  node.finish();
}

void VizConfig::load(ConfigNode& node) {
  node.get("address", address).get("port", port).get("max_client_queue_mb", max_client_queue_mb);
  node.get("max_client_backlog_s", max_client_backlog_s);
  node.get("max_clients", max_clients).get("map_period_s", map_period_s);
  node.get("trajectory_period_s", trajectory_period_s).get("max_trajectory_poses", max_trajectory_poses);
  node.get("world_frame", world_frame).get("imu_frame", imu_frame).get("lidar_frame", lidar_frame);
  node.get("nice", nice);
  node.check(nice >= 0 && nice <= 19, "nice", "must be in [0, 19]");
  node.check(port >= 0 && port <= 65535, "port", "must be in [0, 65535]");
  node.check(std::isfinite(max_client_queue_mb) && max_client_queue_mb >= 1.0 && max_client_queue_mb <= 4096.0,
             "max_client_queue_mb", "must be in [1, 4096] MiB");
  node.check(std::isfinite(max_client_backlog_s) && max_client_backlog_s >= 0.1 && max_client_backlog_s <= 600.0,
             "max_client_backlog_s", "must be in [0.1, 600] s");
  node.check(max_clients >= 1 && max_clients <= 256, "max_clients", "must be in [1, 256]");
  node.check(std::isfinite(map_period_s) && map_period_s >= 0.1 && map_period_s <= 600.0, "map_period_s",
             "must be in [0.1, 600] s");
  node.check(std::isfinite(trajectory_period_s) && trajectory_period_s >= 0.1 && trajectory_period_s <= 600.0,
             "trajectory_period_s", "must be in [0.1, 600] s");
  node.check(max_trajectory_poses >= 100 && max_trajectory_poses <= 10000000, "max_trajectory_poses",
             "must be in [100, 10000000]");
  for (const auto& [key, frame] : {std::pair<const char*, const std::string*>{"world_frame", &world_frame},
                                   {"imu_frame", &imu_frame},
                                   {"lidar_frame", &lidar_frame}}) {
    node.check(!frame->empty() && frame->size() <= 64, key, "must be a name of 1 to 64 characters");
  }
  node.check(world_frame != imu_frame && imu_frame != lidar_frame && world_frame != lidar_frame, "lidar_frame",
             "the three frame names must differ");
  node.finish();
}

void Ros2Config::load(ConfigNode& node) {
  node.get("enabled", enabled).get("odometry_topic", odometry_topic).get("tf_topic", tf_topic);
  node.get("tf_static_topic", tf_static_topic).get("scan_topic", scan_topic).get("map_topic", map_topic);
  node.get("diagnostics_topic", diagnostics_topic).get("world_frame", world_frame).get("imu_frame", imu_frame);
  node.get("lidar_frame", lidar_frame).get("map_period_s", map_period_s);
  for (const auto& [key, topic] : {std::pair<const char*, const std::string*>{"odometry_topic", &odometry_topic},
                                   {"tf_topic", &tf_topic},
                                   {"tf_static_topic", &tf_static_topic},
                                   {"scan_topic", &scan_topic},
                                   {"map_topic", &map_topic},
                                   {"diagnostics_topic", &diagnostics_topic}}) {
    std::string why;
    try {
      transport::ros2::dds_topic(*topic);
    } catch (const std::invalid_argument& e) {
      why = e.what();
    }
    node.check(why.empty(), key, why);
  }
  for (const auto& [key, frame] : {std::pair<const char*, const std::string*>{"world_frame", &world_frame},
                                   {"imu_frame", &imu_frame},
                                   {"lidar_frame", &lidar_frame}}) {
    node.check(!frame->empty() && frame->size() <= 64, key, "must be a name of 1 to 64 characters");
  }
  node.check(std::isfinite(map_period_s) && map_period_s >= 0.1 && map_period_s <= 600.0, "map_period_s",
             "must be in [0.1, 600] s");
  node.finish();
}

int SchedulingConfig::slice_us(const std::string& service) const {
  if (service == "fuse-ingest") return ingest_slice_us;
  if (service == "fuse-state") return state_slice_us;
  if (service == "fuse-update") return update_slice_us;
  if (service == "fuse-map") return map_slice_us;
  return 0;
}

void SchedulingConfig::load(ConfigNode& node) {
  node.get("ingest_slice_us", ingest_slice_us).get("state_slice_us", state_slice_us);
  node.get("update_slice_us", update_slice_us).get("map_slice_us", map_slice_us);
  node.get("cpu_latency_us", cpu_latency_us);
  node.check(cpu_latency_us >= -1 && cpu_latency_us <= kMaxCpuLatencyUs, "cpu_latency_us",
             "must be -1 (no request) or in [0, " + std::to_string(kMaxCpuLatencyUs) + "] us");
  const std::string range = "must be 0 (kernel default) or in [" + std::to_string(kMinSchedulerSliceUs) + ", " +
                            std::to_string(kMaxSchedulerSliceUs) + "] us";
  node.check(valid_scheduler_slice(ingest_slice_us), "ingest_slice_us", range);
  node.check(valid_scheduler_slice(state_slice_us), "state_slice_us", range);
  node.check(valid_scheduler_slice(update_slice_us), "update_slice_us", range);
  node.check(valid_scheduler_slice(map_slice_us), "map_slice_us", range);
  node.finish();
}

void HealthConfig::load(ConfigNode& node) {
  node.get("period_s", period_s).get("instance_window_s", instance_window_s);
  node.check(period_s >= 0.05 && period_s <= 60.0, "period_s", "must be in [0.05, 60] s");
  node.check(std::isfinite(instance_window_s) && instance_window_s >= 2.5 * period_s && instance_window_s <= 600.0,
             "instance_window_s", "must be at least 2.5 health periods (period_s) and at most 600 s");
  node.finish();
}

void SystemConfig::load(ConfigNode& root) {
  load_section(root, "estimator", estimator);
  load_section(root, "transport", transport);
  load_section(root, "ingest", ingest);
  load_section(root, "state", state);
  load_section(root, "update", update);
  load_section(root, "map_server", map_server);
  load_section(root, "scheduling", scheduling);
  load_section(root, "health", health);
  load_section(root, "viz", viz);
  load_section(root, "ros2", ros2);
  // Free-space carving needs each ray's origin, which observations do not carry: the map server
  // cannot carve, and a fuse-update that carved its replica would drift from the map it serves.
  root.check(estimator.map.carve_s == 0.0, "estimator.map.carve_s",
             "must be 0 for the services: free-space carving runs in fuse-run only (the map server's "
             "observations carry no ray origins)");
  root.finish();
}

SystemConfig load_system_config(const std::string& file, const std::vector<std::string>& overrides) {
  ConfigNode node(load_yaml_file(file, overrides), "");
  SystemConfig config;
  config.load(node);
  return config;
}

}  // namespace fuse::service
