#include "runner.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "fuse/core/logging.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/map/map_storage.hpp"

namespace fuse {

void RunnerConfig::load(ConfigNode& root) {
  load_section(root, "estimator", estimator);
  // One config file serves fuse-run and the services: their sections are theirs to validate.
  for (const char* service_section : {"transport", "ingest", "state", "update", "map_server", "scheduling", "health"}) {
    root.child(service_section);
  }
  root.finish();
}

namespace {
void write_timing(const std::string& path, const std::vector<ScanReport>& reports) {
  std::ofstream f(path);
  f << "scan,t,points_in,points_kept,deskew_ms,association_ms,update_ms,map_ms,total_ms\n" << std::fixed;
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const auto& r = reports[i];
    f << i << ',' << std::setprecision(6) << r.t << ',' << r.points_in << ',' << r.points_kept << ','
      << std::setprecision(4) << r.ms_deskew << ',' << r.ms_association << ',' << r.ms_update << ',' << r.ms_map << ','
      << r.ms_total << '\n';
  }
}

void write_diagnostics(const std::string& path, const std::vector<ScanReport>& reports) {
  std::ofstream f(path);
  f << "scan,t,updated,constraints,rejected_no_neighbors,rejected_not_planar,rejected_screening,"
       "min_eig_translation,min_eig_rotation,min_eig_ratio,min_gamma,iterations,converged,map_points,map_inserted\n";
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const auto& r = reports[i];
    f << i << ',' << std::fixed << std::setprecision(6) << r.t << ',' << r.updated << ',' << r.constraints << ','
      << r.rejected_no_neighbors << ',' << r.rejected_not_planar << ',' << r.rejected_screening << ','
      << std::scientific << std::setprecision(4) << r.min_eig_translation << ',' << r.min_eig_rotation << ',' << r.min_eig_ratio << ','
      << std::fixed << r.min_gamma << ',' << r.iterations << ',' << r.converged << ',' << r.map_points << ','
      << r.map_inserted << '\n';
  }
}

StampedPose pose_of(const StateQuery& q) {
  return StampedPose{q.t, q.x.p, Eigen::Quaterniond(q.x.R).normalized()};
}

void summarise_timing(RunSummary& s) {
  if (s.scan_ms.empty()) return;
  std::vector<double> sorted = s.scan_ms;
  std::sort(sorted.begin(), sorted.end());
  double sum = 0.0;
  for (double v : sorted) sum += v;
  s.mean_ms = sum / static_cast<double>(sorted.size());
  s.p95_ms = sorted[std::min(sorted.size() - 1, static_cast<std::size_t>(0.95 * static_cast<double>(sorted.size())))];
  s.max_ms = sorted.back();
}
}  // namespace

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
  std::unique_ptr<io::SensorSource> source;
  try {
    source = io::open_sensor_source(input);
  } catch (const std::exception& e) {
    summary.error = std::string("cannot open input: ") + e.what();
    return summary;
  }
  RunnerConfig config = config_in;
  if (auto T = source->T_imu_lidar()) {
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
    estimator.load_map(points);
    log->info("map {} loaded: {} points; map mode {}", config.load_map, points.size(), config.estimator.map.mode);
  }
  io::SensorEvent ev;
  try {
    while (source->next(ev)) {
      if (ev.kind == io::SensorEvent::Kind::kImu) {
        ++summary.imu_samples;
        estimator.ingest(ev.imu);
        const StateQuery q = estimator.query(ev.imu.t);
        if (q.ok()) summary.trajectory_imu.push_back(pose_of(q));
        continue;
      }
      ++summary.scans;
      const ScanReport report = estimator.ingest(ev.scan);
      if (!estimator.initialised()) continue;
      const StateQuery q = estimator.query(ev.scan.t_end);
      if (!q.ok()) continue;
      reports.push_back(report);
      if (report.updated) ++summary.scans_updated;
      summary.scan_ms.push_back(report.ms_total);
      summary.trajectory.push_back(pose_of(q));
    }
  } catch (const DivergenceError& e) {
    summary.diverged = true;
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
    MapStorage::write_snapshot_file(config.save_map, map, meta);
    log->info("map saved to {}: {} points", config.save_map, map.num_points());
  }
  summary.input_rejected = source->stats().rejected;
  summary.estimator_counts = estimator.counters();
  summarise_timing(summary);
  if (!out_dir.empty()) {
    std::filesystem::create_directories(out_dir);
    eval::write_tum(out_dir + "/trajectory.tum", summary.trajectory);
    eval::write_tum(out_dir + "/trajectory_imu.tum", summary.trajectory_imu);
    write_timing(out_dir + "/timing.csv", reports);
    write_diagnostics(out_dir + "/diagnostics.csv", reports);
  }
  return summary;
}

}  // namespace fuse
