#include "runner.hpp"

#include <unistd.h>

#include <algorithm>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>

#include "fuse/core/logging.hpp"
#include "fuse/core/progress.hpp"
#include "fuse/eval/scan_times.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/io/prefetch_source.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/map/map_storage.hpp"

namespace fuse {

void RunnerConfig::load(ConfigNode& root) {
  load_section(root, "estimator", estimator);
  // One config file serves fuse-run and the services: their sections are theirs to validate.
  for (const char* service_section : {"transport", "ingest", "state", "update", "map_server", "scheduling", "health", "viz", "ros2"}) {
    root.child(service_section);
  }
  root.finish();
}

namespace {
/// Events read ahead of the estimator: 2 s of a 200 Hz IMU and its scans.
constexpr std::size_t kPrefetchEvents = 400;

void write_timing(const std::string& path, const std::vector<ScanReport>& reports) {
  std::ofstream f(path);
  f << "scan,t,points_in,points_kept,deskew_ms,association_ms,update_ms,map_ms,total_ms,cpu_ms,page_faults,map_searches\n" << std::fixed;
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const auto& r = reports[i];
    f << i << ',' << std::setprecision(6) << r.t << ',' << r.points_in << ',' << r.points_kept << ','
      << std::setprecision(4) << r.ms_deskew << ',' << r.ms_association << ',' << r.ms_update << ',' << r.ms_map << ','
      << r.ms_total << ',' << r.ms_cpu << ',' << r.page_faults << ',' << r.map_searches << '\n';
  }
}

void write_diagnostics(const std::string& path, const std::vector<ScanReport>& reports,
                       const std::vector<TrackingStatus>& status) {
  std::ofstream f(path);
  f << "scan,t,updated,constraints,rejected_no_neighbors,rejected_not_planar,rejected_screening,"
       "min_eig_translation,min_eig_rotation,min_eig_ratio,min_gamma,iterations,converged,map_points,map_inserted,map_pending,map_carved,moving_screened,"
       "recovery,fit,match_fit,prior_position_std,prior_rotation_std,time_offset_s,tracking,"
       "ext_rx_deg,ext_ry_deg,ext_rz_deg,ext_x,ext_y,ext_z,ext_held,at_rest\n";
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const auto& r = reports[i];
    f << i << ',' << std::fixed << std::setprecision(6) << r.t << ',' << r.updated << ',' << r.constraints << ','
      << r.rejected_no_neighbors << ',' << r.rejected_not_planar << ',' << r.rejected_screening << ','
      << std::scientific << std::setprecision(4) << r.min_eig_translation << ',' << r.min_eig_rotation << ',' << r.min_eig_ratio << ','
      << std::fixed << r.min_gamma << ',' << r.iterations << ',' << r.converged << ',' << r.map_points << ','
      << r.map_inserted << ',' << r.map_pending << ',' << r.map_carved << ',' << r.moving_screened << ',' << r.recovery << ',' << r.fit << ',' << r.match_fit << ',' << r.prior_position_std
      << ',' << r.prior_rotation_std << ',' << std::setprecision(6) << r.time_offset << ',' << to_string(status[i]);
    const Eigen::Vector3d rv = r.extrinsic_rotation * (180.0 / M_PI);
    f << ',' << rv.x() << ',' << rv.y() << ',' << rv.z() << ',' << r.extrinsic_translation.x() << ','
      << r.extrinsic_translation.y() << ',' << r.extrinsic_translation.z() << ',' << static_cast<int>(r.extrinsic_held) << ',' << r.at_rest << '\n';
  }
}

StampedPose pose_of(const StateQuery& q) {
  return StampedPose{q.t, q.x.p, Eigen::Quaterniond(q.x.R).normalized()};
}

/// The tracking status at the end, its episodes, and whether the run diverged by it: lost at the
/// end, or lost for longer than estimator.tracking.max_lost_s in one episode.
void summarise_tracking(const Estimator& estimator, const TrackingConfig& config, RunSummary& s) {
  s.initialised = estimator.initialised();
  const TrackingMonitor& m = estimator.tracking();
  s.tracking = m.status();
  s.tracking_reason = m.reason();
  s.episodes = m.episodes();
  s.relocalizing_s = m.time_in(TrackingStatus::kRelocalizing);
  s.lost_s = m.time_in(TrackingStatus::kLost);
  if (s.diverged || !s.initialised) return;
  if (m.status() == TrackingStatus::kLost) {
    s.diverged = true;
    s.divergence = "lost at the end of the run: " + m.reason();
    return;
  }
  for (const TrackingMonitor::Episode& e : s.episodes) {
    if (e.status == TrackingStatus::kLost && e.duration > config.max_lost_s) {
      s.diverged = true;
      s.divergence = fmt::format("lost for {:.1f} s from t={:.3f} (longer than estimator.tracking.max_lost_s = {} s): {}",
                                 e.duration, e.t_begin, config.max_lost_s, e.reason);
      return;
    }
  }
}

void summarise_timing(RunSummary& s) {
  const eval::TimeStatistics stats = eval::time_statistics(s.scan_ms);
  s.mean_ms = stats.mean_ms;
  s.p95_ms = stats.p95_ms;
  s.max_ms = stats.max_ms;
  const eval::TimeStatistics cpu = eval::time_statistics(s.scan_cpu_ms);
  s.cpu_median_ms = cpu.median_ms;
  s.cpu_p99_ms = cpu.p99_ms;
  s.cpu_max_ms = cpu.max_ms;
}
}  // namespace

std::string prepare_output_dir(const std::string& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return "cannot create output directory '" + out_dir + "': " + ec.message();
  if (!std::filesystem::is_directory(out_dir, ec)) return "output path '" + out_dir + "' is not a directory";
  if (::access(out_dir.c_str(), W_OK | X_OK) != 0) return "output directory '" + out_dir + "' is not writable";
  return "";
}

RunnerConfig load_runner_config(const std::string& file, const std::vector<std::string>& overrides) {
  ConfigNode node(load_yaml_file(file, overrides), "");
  RunnerConfig config;
  config.load(node);
  return config;
}


RunSummary run_offline(const RunnerConfig& config_in, const std::string& input, const std::string& out_dir) {
  auto log = logger("run");
  RunSummary summary;
  std::vector<ScanReport> reports;
  std::vector<TrackingStatus> status;  ///< after each report
  std::unique_ptr<io::SensorSource> source;
  try {
    // Read ahead on a thread of its own, as fuse-ingest does: decoding a recording's chunk would
    // otherwise run between two scans on the estimator's thread and be felt by the next scans
    // (their data evicted from the caches). The events and the counters come out unchanged.
    source = std::make_unique<io::PrefetchSource>(io::open_sensor_source(input, config_in.estimator.clock), kPrefetchEvents);
  } catch (const std::exception& e) {
    summary.error = std::string("cannot open input: ") + e.what();
    return summary;
  }
  RunnerConfig config = config_in;
  // An offline replay runs faster than the data: a search in a thread of its own would finish
  // after the replay had moved on (or ended), and whether the run located itself would depend
  // on the machine's speed. fuse-run waits for each search instead (a live system locates a
  // search's duration of data later).
  config.estimator.global_localization.blocking = true;
  if (auto T = source->T_imu_lidar(); T && config.extrinsic_from == "config") {
    log->info("extrinsic T_imu_lidar from the config (--extrinsic-from config), not the input's: t = [{:.4f} {:.4f} {:.4f}]",
              config.estimator.T_imu_lidar.translation().x(), config.estimator.T_imu_lidar.translation().y(),
              config.estimator.T_imu_lidar.translation().z());
  } else if (T) {
    config.estimator.T_imu_lidar = *T;
    log->info("extrinsic T_imu_lidar from the input overrides the config: t = [{:.4f} {:.4f} {:.4f}]",
              T->translation().x(), T->translation().y(), T->translation().z());
  }
  Estimator estimator(config.estimator);
  if (!config.load_map.empty()) {
    PointMap map;
    MapMeta meta;
    const LoadReport report = MapStorage::read_snapshot_file(config.load_map, map, meta);
    if (!report.snapshot_ok || map.num_points() == 0) {
      summary.error = "cannot load map '" + config.load_map + "'";
      return summary;
    }
    std::vector<Eigen::Vector3f> points;
    map.for_each_chunk([&](const PointChunk& c) { points.insert(points.end(), c.points.begin(), c.points.end()); });
    log->info("map {} loaded: {} points; map mode {}", config.load_map, points.size(), config.estimator.map.mode);
    if (config.estimator.global_localization.enabled || config.initial_pose) {
      try {
        estimator.localize_in(std::move(points), config.initial_pose, meta.gravity);
      } catch (const std::invalid_argument& e) {
        summary.error = std::string("cannot search the map: ") + e.what();
        return summary;
      }
      summary.searched_map = true;
      log->info("searching the map for the start{}", config.initial_pose ? " around the initial pose" : "");
    } else {
      estimator.load_map(points);  // the session starts at the map's origin
    }
  }
  // Poses taken before the run found itself in the map are kept with the T_M_S of their time and
  // written in the map's frame once it is confirmed: T_M_S(final) · T_M_S(then)⁻¹ · pose.
  struct Held {
    StampedPose pose;
    Eigen::Isometry3d T_then;
    bool imu_rate;
  };
  std::vector<Held> held;
  auto emit = [&](const StampedPose& pose, bool imu_rate) {
    if (!estimator.localized()) {
      held.push_back({pose, estimator.T_map_session(), imu_rate});
      return;
    }
    if (!held.empty()) {
      for (const Held& h : held) {
        Eigen::Isometry3d T_WI = Eigen::Isometry3d::Identity();
        T_WI.linear() = h.pose.q.toRotationMatrix();
        T_WI.translation() = h.pose.p;
        const Eigen::Isometry3d moved = estimator.T_map_session() * h.T_then.inverse() * T_WI;
        const StampedPose p{h.pose.t, moved.translation(), Eigen::Quaterniond(moved.linear()).normalized()};
        (h.imu_rate ? summary.trajectory_imu : summary.trajectory).push_back(p);
      }
      held.clear();
      summary.localized = true;
      summary.localized_t = pose.t;
    }
    (imu_rate ? summary.trajectory_imu : summary.trajectory).push_back(pose);
  };
  io::SensorEvent ev;
  std::uint64_t scans_refused = 0;  ///< by the source's checks
  auto note_refused_scans = [&] {   // they arrived: time without a LiDAR update for the tracking status
    estimator.note_refused_scans(source->stats().scans_refused - scans_refused);
    scans_refused = source->stats().scans_refused;
  };
  Progress progress("run", source->expected_events());
  std::deque<LidarScan> waiting;  // at most one: a scan whose end the IMU has not reached yet
  double imu_reached = -std::numeric_limits<double>::infinity();  // the newest sample, on the state's clock
  auto process_scan = [&] {
    const LidarScan scan = std::move(waiting.front());
    waiting.pop_front();
    const ScanReport report = estimator.ingest(scan);
    if (!estimator.initialised()) return;
    const StateQuery q = estimator.query(scan.t_end);
    if (!q.ok()) return;
    reports.push_back(report);
    // Not yet located in the loaded map: relocalizing, whatever the session's own tracking says.
    status.push_back(estimator.localized() ? estimator.tracking().status() : TrackingStatus::kRelocalizing);
    if (report.updated) ++summary.scans_updated;
    summary.moving_screened += report.moving_screened;
    summary.map_carved += report.map_carved;
    summary.scan_ms.push_back(report.ms_total);
    summary.scan_cpu_ms.push_back(report.ms_cpu);
    emit(pose_of(q), false);
  };
  try {
    while (source->next(ev)) {
      note_refused_scans();
      progress.update(summary.imu_samples + summary.scans, ev.kind == io::SensorEvent::Kind::kImu ? ev.imu.t : ev.scan.t_end,
                      estimator.localized() ? std::string(to_string(estimator.tracking().status()))
                                            : "relocalizing: " + estimator.map_localization()->describe());
      if (ev.kind == io::SensorEvent::Kind::kImu) {
        ++summary.imu_samples;
        estimator.ingest(ev.imu);
        // At the sample's place on the state's clock (the LiDAR's: its stamp less the time offset).
        const double t = estimator.state_time(ev.imu.t);
        const StateQuery q = estimator.query(t);
        if (q.ok()) emit(pose_of(q), true);
        imu_reached = t;
        while (!waiting.empty() && waiting.front().t_end <= imu_reached) process_scan();
        continue;
      }
      ++summary.scans;
      // A scan waits until the IMU covers its end on the state's clock, as fuse-state waits for it:
      // with the IMU's clock behind, its samples up to the scan end come after the scan. Not
      // beyond a data gap (divergence.max_imu_gap): an IMU silent that long has dropped out, and
      // the scan coasts at once; nor beyond the next scan.
      while (!waiting.empty()) process_scan();
      waiting.push_back(std::move(ev.scan));
      const double t_end = waiting.front().t_end;
      if (t_end <= imu_reached || t_end > imu_reached + config.estimator.divergence.max_imu_gap) process_scan();
    }
    while (!waiting.empty()) process_scan();
    note_refused_scans();
  } catch (const DivergenceError& e) {
    summary.diverged = true;
    summary.divergence = e.what();
    summary.error = std::string("estimator diverged: ") + e.what();
  } catch (const io::InputError& e) {
    summary.error = std::string("input error: ") + e.what();
  }
  if (!config.save_map.empty() && summary.error.empty()) {
    PointMap map;
    std::vector<Eigen::Vector3f> points;
    estimator.map().for_each_point([&](const Eigen::Vector3f& p) { points.push_back(p); });
    map.insert(points);
    MapMeta meta;
    meta.min_point_distance = config.estimator.map.min_point_distance;
    meta.mode = config.estimator.map.mode;
    // The gravity direction the map's frame ended with (the estimate's, in the map frame): a later
    // session that searches the map checks it.
    if (estimator.initialised() && estimator.localized()) {
      const Eigen::Vector3d g = estimator.latest().x.g;
      if (g.allFinite() && g.norm() > 0.0) meta.gravity = g.normalized();
    }
    MapStorage::write_snapshot_file(config.save_map, map, meta);
    log->info("map saved to {}: {} points", config.save_map, map.num_points());
  }
  summary.time_offset = estimator.initialised() ? estimator.latest().x.td : config.estimator.time_offset.initial_s;
  summary.R_IL = estimator.initialised() ? estimator.latest().x.R_IL : config.estimator.T_imu_lidar.rotation();
  summary.p_IL = estimator.initialised() ? estimator.latest().x.p_IL : config.estimator.T_imu_lidar.translation();
  if (const MapLocalization* L = estimator.map_localization()) {
    summary.searches = L->searches();
    summary.search_s = L->search_seconds();
    summary.localization = L->describe();
    summary.initial_pose_refused = L->initial_pose_refused();
    if (summary.localized && !summary.trajectory.empty()) {
      summary.localized_after_s = summary.localized_t - summary.trajectory.front().t;
    }
    if (!summary.localized && summary.error.empty() && !summary.diverged && estimator.initialised()) {
      // Never found in the map: no pose in its frame was produced. Not silent: exit 3.
      summary.diverged = true;
      summary.divergence = "not localized in the loaded map by the end of the run (" + L->describe() + ")";
    }
  }
  summary.input_rejected = source->stats().rejected;
  summary.estimator_counts = estimator.counters();
  summarise_timing(summary);
  summarise_tracking(estimator, config.estimator.tracking, summary);
  if (!out_dir.empty()) {
    const std::string why = prepare_output_dir(out_dir);
    if (!why.empty()) {
      if (summary.error.empty()) summary.error = why;
      return summary;
    }
    try {
      eval::write_tum(out_dir + "/trajectory.tum", summary.trajectory);
      eval::write_tum(out_dir + "/trajectory_imu.tum", summary.trajectory_imu);
    } catch (const std::exception& e) {
      if (summary.error.empty()) summary.error = e.what();
    }
    write_timing(out_dir + "/timing.csv", reports);
    write_diagnostics(out_dir + "/diagnostics.csv", reports, status);
  }
  return summary;
}

}  // namespace fuse
