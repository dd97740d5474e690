#include "fuse/sim/simulator.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>

#include "fuse/core/logging.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/foxglove/messages.hpp"
#include "fuse/io/recording.hpp"
#include "fuse/io/seqdir.hpp"
#include "fuse/sim/imu_model.hpp"
#include "fuse/sim/lidar_model.hpp"
#include "fuse/sim/point_labels.hpp"
#include "fuse/sim/scenario.hpp"

namespace fuse::sim {

namespace {

constexpr int kYamlPrecision = 12;         // significant digits of doubles in scenario.yaml
constexpr double kProgressPeriodS = 30.0;  // simulated seconds between progress log lines

constexpr double kTrajectoryPeriodS = 1.0;  // the truth path so far is drawn at most this often

Eigen::Isometry3d isometry(const TrajectoryState& s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = s.R;
  T.translation() = s.p;
  return T;
}

/// The Foxglove channels of an MCAP output (the names fuse-viz and fuse-record use), here with the
/// simulator's truth: /tf (world -> imu) and /fuse/pose at every scan end, /tf_static, /fuse/scan
/// (each point placed in the world by the true pose at its own time: deskewed with the truth) and
/// /fuse/trajectory (the true path so far), so that the recording draws in Foxglove.
class FoxgloveChannels {
 public:
  FoxgloveChannels(io::RecordingWriter& w, const Eigen::Isometry3d& T_imu_lidar) : w_(w), T_imu_lidar_(T_imu_lidar) {
    namespace fx = foxglove;
    const auto add = [&](const char* topic, const fx::JsonSchema& s) { return w_.add_json_channel(topic, s.name, s.text); };
    pose_ = add(fx::topics::kPose, fx::pose_in_frame_schema());
    tf_ = add(fx::topics::kTf, fx::frame_transforms_schema());
    tf_static_ = add(fx::topics::kTfStatic, fx::frame_transforms_schema());
    scan_ = add(fx::topics::kScan, fx::point_cloud_schema());
    trajectory_ = add(fx::topics::kTrajectory, fx::poses_in_frame_schema());
  }
  void write(const LidarScan& scan, const Trajectory& truth) {
    namespace fx = foxglove;
    const std::uint64_t ns = fx::to_nanoseconds(scan.t_end);
    const Eigen::Isometry3d T_end = isometry(truth.state(scan.t_end));
    if (!static_written_) {
      w_.write_json(tf_static_, ns, fx::frame_transforms_json({{scan.t_end, "imu", "lidar", T_imu_lidar_}}));
      static_written_ = true;
    }
    w_.write_json(tf_, ns, fx::frame_transforms_json({{scan.t_end, "world", "imu", T_end}}));
    w_.write_json(pose_, ns, fx::pose_in_frame_json(scan.t_end, "world", T_end));
    // Each point by the true pose at its time, interpolated between the scan's start and end.
    const Eigen::Isometry3d T_start = isometry(truth.state(scan.t_start));
    const Eigen::Quaterniond q0(T_start.linear()), q1(T_end.linear());
    const double span = std::max(scan.t_end - scan.t_start, 1e-9);
    std::vector<float> xyz;
    xyz.reserve(3 * scan.points.size());
    for (const LidarPoint& p : scan.points) {
      const double a = std::clamp(static_cast<double>(p.t_rel) / span, 0.0, 1.0);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = q0.slerp(a, q1).toRotationMatrix();
      T.translation() = (1.0 - a) * T_start.translation() + a * T_end.translation();
      const Eigen::Vector3d w = T * T_imu_lidar_ * Eigen::Vector3d(p.x, p.y, p.z);
      xyz.insert(xyz.end(), {static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z())});
    }
    w_.write_json(scan_, ns, fx::point_cloud_json(scan.t_end, "world", xyz));
    path_.push_back(T_end);
    if (scan.t_end >= next_trajectory_t_) {
      w_.write_json(trajectory_, ns, fx::poses_in_frame_json(scan.t_end, "world", path_));
      next_trajectory_t_ = scan.t_end + kTrajectoryPeriodS;
    }
  }

 private:
  io::RecordingWriter& w_;
  Eigen::Isometry3d T_imu_lidar_;
  std::uint16_t pose_ = 0, tf_ = 0, tf_static_ = 0, scan_ = 0, trajectory_ = 0;
  bool static_written_ = false;
  std::vector<Eigen::Isometry3d> path_;
  double next_trajectory_t_ = 0.0;
};

// Either output format behind one interface.
class Output {
 public:
  Output(const SimOptions& o, const Eigen::Isometry3d& T_imu_lidar) {
    if (o.format == OutputFormat::kMcap) {
      mcap_ = std::make_unique<io::RecordingWriter>((std::filesystem::path(o.out_dir) / "recording.mcap").string());
      mcap_->set_calibration(T_imu_lidar);
      foxglove_ = std::make_unique<FoxgloveChannels>(*mcap_, T_imu_lidar);
    } else {
      seqdir_ = std::make_unique<io::SeqdirWriter>(o.out_dir, T_imu_lidar);
    }
  }
  void write(const ImuSample& s) { mcap_ ? mcap_->write(s) : seqdir_->write(s); }
  void write(const LidarScan& s, const Trajectory& truth) {
    if (!mcap_) return seqdir_->write(s);
    mcap_->write(s);
    foxglove_->write(s, truth);
  }
  void close(const std::vector<StampedPose>& scan_end_poses) {
    if (mcap_) {
      mcap_->close();
    } else {
      seqdir_->write_groundtruth(scan_end_poses);
      seqdir_->close();
    }
  }

 private:
  std::unique_ptr<io::RecordingWriter> mcap_;
  std::unique_ptr<FoxgloveChannels> foxglove_;
  std::unique_ptr<io::SeqdirWriter> seqdir_;
};

StampedPose to_pose(const TrajectoryState& s) {
  StampedPose p;
  p.t = s.t;
  p.p = s.p;
  p.q = Eigen::Quaterniond(s.R).normalized();
  return p;
}

void emit_vector(YAML::Emitter& y, const Eigen::Vector3d& v) {
  y << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}

void emit_oscillations(YAML::Emitter& y, const char* key, const std::vector<Oscillation>& terms) {
  y << YAML::Key << key << YAML::Value << YAML::BeginSeq;
  for (const Oscillation& o : terms)
    y << YAML::Flow << YAML::BeginMap << YAML::Key << "amplitude" << YAML::Value << o.amplitude << YAML::Key
      << "frequency_hz" << YAML::Value << o.frequency_hz << YAML::Key << "phase_rad" << YAML::Value << o.phase
      << YAML::EndMap;
  y << YAML::EndSeq;
}

struct RunFacts {
  std::size_t scans, imu_samples, points;
  double duration_s, full_duration_s, path_length_m, travelled_m;
  std::size_t moving_points, scans_with_moving_points;
  double mean_scan_moving_fraction;  ///< per-scan share of moving points, averaged over the scans
};

void emit_speed_law(YAML::Emitter& y, const TimeLawConfig& law) {
  if (law.limits.empty()) return;
  y << YAML::Key << "max_accel_mps2" << YAML::Value << law.max_accel;
  y << YAML::Key << "speed_limits" << YAML::Value << YAML::BeginSeq;
  for (const SpeedLimit& l : law.limits)
    y << YAML::Flow << YAML::BeginMap << YAML::Key << "u_begin_m" << YAML::Value << l.u_begin << YAML::Key
      << "u_end_m" << YAML::Value << l.u_end << YAML::Key << "rate_mps" << YAML::Value << l.rate << YAML::EndMap;
  y << YAML::EndSeq;
}

void emit_suspension(YAML::Emitter& y, const SuspensionConfig& c) {
  if (!c.enabled) return;
  y << YAML::Key << "suspension" << YAML::Value << YAML::BeginMap << YAML::Key << "pitch_rad_per_mps2"
    << YAML::Value << c.pitch_per_accel << YAML::Key << "roll_rad_per_mps2" << YAML::Value << c.roll_per_accel
    << YAML::Key << "natural_hz" << YAML::Value << c.natural_hz << YAML::Key << "damping_ratio" << YAML::Value
    << c.damping_ratio << YAML::EndMap;
}

void emit_vibration(YAML::Emitter& y, const VibrationConfig& v) {
  if (!v.enabled) return;
  y << YAML::Key << "vibration" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "reference_speed_mps" << YAML::Value << v.reference_speed_mps << YAML::Key << "engine_rise"
    << YAML::Value << v.engine_rise << YAML::Key << "idle_share" << YAML::Value << v.idle_share;
  y << YAML::Key << "engine" << YAML::Value << YAML::BeginSeq;
  for (const EngineComponent& e : v.engine) {
    y << YAML::BeginMap << YAML::Key << "idle_hz" << YAML::Value << e.idle_hz << YAML::Key << "accel_amplitude"
      << YAML::Value;
    emit_vector(y, e.accel_amplitude);
    y << YAML::Key << "gyro_amplitude" << YAML::Value;
    emit_vector(y, e.gyro_amplitude);
    y << YAML::Key << "phase_rad" << YAML::Value << e.phase << YAML::EndMap;
  }
  y << YAML::EndSeq;
  y << YAML::Key << "road_center_hz" << YAML::Value << v.road_center_hz << YAML::Key << "road_q" << YAML::Value
    << v.road_q << YAML::Key << "road_accel_rms" << YAML::Value;
  emit_vector(y, v.road_accel_rms);
  y << YAML::Key << "road_gyro_rms" << YAML::Value;
  emit_vector(y, v.road_gyro_rms);
  y << YAML::EndMap;
}

void emit_traffic(YAML::Emitter& y, const SimOptions& o, const Scenario& sc) {
  if (!scenario_has_traffic(o.scenario)) return;
  const TrafficStats& t = sc.traffic_stats;
  y << YAML::Key << "traffic" << YAML::Value << YAML::BeginMap << YAML::Key << "enabled" << YAML::Value << o.traffic
    << YAML::Key << "cars" << YAML::Value << t.cars << YAML::Key << "pedestrians" << YAML::Value << t.pedestrians
    << YAML::Key << "redraws" << YAML::Value << t.redraws << YAML::Key << "off_route_draws" << YAML::Value
    << t.off_route << YAML::Key << "dropped" << YAML::Value << t.dropped
    << YAML::Key << "file" << YAML::Value << "moving_objects.csv" << YAML::EndMap;
}

void emit_labels(YAML::Emitter& y, const RunFacts& f) {
  y << YAML::Key << "labels" << YAML::Value << YAML::BeginMap << YAML::Key << "file" << YAML::Value
    << "point_labels.bin" << YAML::Key << "points_total" << YAML::Value << f.points << YAML::Key
    << "moving_points_total" << YAML::Value << f.moving_points << YAML::Key << "moving_fraction" << YAML::Value
    << (f.points > 0 ? static_cast<double>(f.moving_points) / static_cast<double>(f.points) : 0.0) << YAML::Key
    << "moving_fraction_mean_per_scan" << YAML::Value << f.mean_scan_moving_fraction << YAML::Key
    << "scans_with_moving_points" << YAML::Value << f.scans_with_moving_points << YAML::EndMap;
}

void write_scenario_yaml(const std::string& file, const SimOptions& o, const Scenario& sc, const LidarConfig& lidar,
                         const ImuNoiseConfig& imu, const ImuSimulator& imu_sim, const Eigen::Isometry3d& T,
                         const RunFacts& f) {
  const Trajectory& tr = *sc.trajectory;
  YAML::Emitter y;
  y.SetDoublePrecision(kYamlPrecision);
  y << YAML::BeginMap;
  y << YAML::Key << "scenario" << YAML::Value << o.scenario;
  y << YAML::Key << "seed" << YAML::Value << o.seed;
  y << YAML::Key << "world_seed" << YAML::Value << o.world_seed;
  y << YAML::Key << "laps" << YAML::Value << o.laps;
  y << YAML::Key << "start_at_m" << YAML::Value << o.start_at_m;
  y << YAML::Key << "format" << YAML::Value << (o.format == OutputFormat::kMcap ? "mcap" : "seqdir");
  y << YAML::Key << "imu_time_offset_s" << YAML::Value << o.imu_time_offset_s;
  y << YAML::Key << "time" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "t0_s" << YAML::Value << tr.t_begin() << YAML::Key << "duration_s" << YAML::Value << f.duration_s
    << YAML::Key << "scenario_duration_s" << YAML::Value << f.full_duration_s << YAML::Key << "scans" << YAML::Value
    << f.scans << YAML::Key << "imu_samples" << YAML::Value << f.imu_samples << YAML::Key << "points" << YAML::Value
    << f.points << YAML::EndMap;
  y << YAML::Key << "trajectory" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "path_length_m" << YAML::Value << f.path_length_m;
  y << YAML::Key << "travelled_length_m" << YAML::Value << f.travelled_m;
  const TimeLawConfig& law = tr.time_law().config();
  y << YAML::Key << "rate_mps" << YAML::Value << law.rate << YAML::Key << "rest_start_s" << YAML::Value
    << law.rest_start_s << YAML::Key << "ramp_s" << YAML::Value << law.ramp_s << YAML::Key << "rest_end_s"
    << YAML::Value << law.rest_end_s;
  emit_speed_law(y, law);
  const MotionConfig& m = tr.motion();
  y << YAML::Key << "pitch_offset_rad" << YAML::Value << m.pitch_offset << YAML::Key << "roll_offset_rad"
    << YAML::Value << m.roll_offset;
  emit_oscillations(y, "lateral_m", m.lateral);
  emit_oscillations(y, "vertical_m", m.vertical);
  emit_oscillations(y, "roll_rad", m.roll);
  emit_oscillations(y, "pitch_rad", m.pitch);
  emit_oscillations(y, "yaw_rad", m.yaw);
  emit_suspension(y, m.suspension);
  y << YAML::EndMap;
  y << YAML::Key << "world" << YAML::Value << YAML::BeginMap << YAML::Key << "boxes" << YAML::Value
    << sc.world.boxes().size() << YAML::Key << "planes" << YAML::Value << sc.world.planes().size();
  for (const auto& [key, value] : sc.parameters) y << YAML::Key << key << YAML::Value << value;
  y << YAML::EndMap;
  y << YAML::Key << "lidar" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "model" << YAML::Value << lidar.name << YAML::Key << "frame_period_s" << YAML::Value
    << lidar.frame_period_s << YAML::Key << "shots_per_frame" << YAML::Value << lidar.shots_per_frame() << YAML::Key
    << "blind_range_m" << YAML::Value << lidar.blind_range_m << YAML::Key << "max_range_m" << YAML::Value
    << lidar.max_range_m << YAML::Key << "range_noise_sigma_m" << YAML::Value << lidar.range_noise_sigma_m
    << YAML::Key << "angular_noise_sigma_rad" << YAML::Value << lidar.angular_noise_sigma_rad << YAML::Key
    << "elevation_min_deg" << YAML::Value << lidar.elevation_min_deg << YAML::Key << "elevation_max_deg"
    << YAML::Value << lidar.elevation_max_deg;
  if (lidar.type == LidarType::kMid360)
    y << YAML::Key << "lines" << YAML::Value << lidar.lines << YAML::Key << "point_rate_hz" << YAML::Value
      << lidar.point_rate_hz << YAML::Key << "azimuth_rev_hz" << YAML::Value << lidar.azimuth_rev_hz << YAML::Key
      << "elevation_osc_hz" << YAML::Value << lidar.elevation_osc_hz;
  else
    y << YAML::Key << "beams" << YAML::Value << lidar.beams << YAML::Key << "columns" << YAML::Value
      << lidar.columns;
  y << YAML::EndMap;
  y << YAML::Key << "imu" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "rate_hz" << YAML::Value << imu.rate_hz << YAML::Key << "gyro_noise_density" << YAML::Value
    << imu.gyro_noise_density << YAML::Key << "accel_noise_density" << YAML::Value << imu.accel_noise_density
    << YAML::Key << "gyro_bias_random_walk" << YAML::Value << imu.gyro_bias_random_walk << YAML::Key
    << "accel_bias_random_walk" << YAML::Value << imu.accel_bias_random_walk;
  y << YAML::Key << "initial_gyro_bias" << YAML::Value;
  emit_vector(y, imu_sim.initial_gyro_bias());
  y << YAML::Key << "initial_accel_bias" << YAML::Value;
  emit_vector(y, imu_sim.initial_accel_bias());
  y << YAML::Key << "final_gyro_bias" << YAML::Value;
  emit_vector(y, imu_sim.gyro_bias());
  y << YAML::Key << "final_accel_bias" << YAML::Value;
  emit_vector(y, imu_sim.accel_bias());
  y << YAML::Key << "gravity" << YAML::Value;
  emit_vector(y, kGravityWorld);
  emit_vibration(y, imu.vibration);
  y << YAML::EndMap;
  emit_traffic(y, o, sc);
  emit_labels(y, f);
  const Eigen::Quaterniond q(T.linear());
  y << YAML::Key << "T_imu_lidar" << YAML::Value << YAML::BeginMap << YAML::Key << "translation" << YAML::Value;
  emit_vector(y, T.translation());
  y << YAML::Key << "rotation_xyzw" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.x() << q.y() << q.z()
    << q.w() << YAML::EndSeq << YAML::Key << "rotation_rpy_deg" << YAML::Value;
  emit_vector(y, kLidarInImuRpyDeg);
  y << YAML::EndMap << YAML::EndMap;
  std::ofstream out(file);
  out << "# fuse-sim: every parameter of this run (p_imu = R p_lidar + t; ground truth is T_world_imu)\n"
      << y.c_str() << "\n";
  if (!out) throw std::runtime_error(file + ": cannot write");
}

void prepare_out_dir(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw std::invalid_argument("--out: '" + dir + "' exists and is not a directory");
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("--out: cannot create '" + dir + "': " + ec.message());
}

}  // namespace

SimSummary run_simulation(const SimOptions& o) {
  const auto log = fuse::logger("sim");
  const auto wall_start = std::chrono::steady_clock::now();
  prepare_out_dir(o.out_dir);
  const Scenario sc = make_scenario(o.scenario, o.world_seed, o.seed, kStartTime, o.laps, o.start_at_m, o.traffic, o.stops);
  const Trajectory& tr = *sc.trajectory;
  const LidarConfig lidar = LidarConfig::from_name(o.lidar);
  ImuNoiseConfig imu_cfg;
  if (sc.vehicle_vibration) imu_cfg.vibration = vehicle_vibration(o.seed);
  const Eigen::Isometry3d T_imu_lidar = default_T_imu_lidar();

  const double full = tr.t_end() - tr.t_begin();
  double duration = full;
  if (o.duration_s) {
    if (*o.duration_s > full)
      log->warn("--duration {} s exceeds the scenario's {:.3f} s; simulating the whole scenario", *o.duration_s, full);
    else
      duration = *o.duration_s;
  }
  // Scans are whole frames [t0 + k T, t0 + (k+1) T]; IMU samples at t0 + i / rate.
  const long imu_per_scan = std::lround(imu_cfg.rate_hz * lidar.frame_period_s);
  const std::size_t n_scans = static_cast<std::size_t>(std::floor(duration / lidar.frame_period_s + 1e-9));
  const std::size_t n_imu = static_cast<std::size_t>(std::floor(duration * imu_cfg.rate_hz + 1e-9)) + 1;
  if (n_scans == 0) throw std::invalid_argument("--duration: shorter than one LiDAR frame");
  const double path_length = tr.path().arc_length();
  log->info("scenario {} (world seed {}, seed {}): {} boxes, {} planes, path {:.2f} m, {:.2f} s, {} scans, lidar {}",
            o.scenario, o.world_seed, o.seed, sc.world.boxes().size(), sc.world.planes().size(), path_length, duration,
            n_scans, lidar.name);
  if (sc.traffic)
    log->info("traffic: {} cars, {} pedestrians ({} draws moved clear of the platform, {} given up)",
              sc.traffic_stats.cars, sc.traffic_stats.pedestrians, sc.traffic_stats.redraws, sc.traffic_stats.dropped);
  const std::filesystem::path dir(o.out_dir);
  PointLabelWriter label_file((dir / "point_labels.bin").string(), n_scans);
  if (sc.traffic)
    sc.traffic->write_csv((dir / "moving_objects.csv").string());
  else
    Traffic().write_csv((dir / "moving_objects.csv").string());  // the header only

  Output output(o, T_imu_lidar);
  ImuSimulator imu(imu_cfg, o.seed);
  LidarSimulator lidar_sim(lidar, sc.world, tr, T_imu_lidar, o.seed, sc.traffic ? &*sc.traffic : nullptr);
  std::vector<StampedPose> groundtruth, scan_ends;
  groundtruth.reserve(n_imu);
  std::size_t imu_next = 0, points = 0, moving_points = 0, scans_with_moving = 0;
  double scan_fraction_sum = 0.0;
  std::vector<std::uint8_t> labels;
  double travelled = 0.0, next_progress = kProgressPeriodS;
  auto write_imu_until = [&](std::size_t last) {
    for (; imu_next <= last && imu_next < n_imu; ++imu_next) {
      const double t_true = tr.t_begin() + static_cast<double>(imu_next) / imu_cfg.rate_hz;
      const TrajectoryState s = tr.state(t_true);
      ImuSample m = imu.measure(s);
      if (o.imu_time_offset_s != 0.0) m.t = t_true + o.imu_time_offset_s;  // the IMU's clock (--imu-time-offset)
      output.write(m);
      if (!groundtruth.empty()) travelled += (s.p - groundtruth.back().p).norm();
      groundtruth.push_back(to_pose(s));
    }
  };
  for (std::size_t k = 0; k < n_scans; ++k) {
    if (o.imu_time_offset_s == 0.0) {
      write_imu_until((k + 1) * static_cast<std::size_t>(imu_per_scan));  // IMU up to the scan end first
    } else {
      // In stamp order: the samples stamped (true time + offset) at or before the scan end.
      const double t_end = tr.t_begin() + static_cast<double>(k + 1) * lidar.frame_period_s;
      while (imu_next < n_imu &&
             tr.t_begin() + static_cast<double>(imu_next) / imu_cfg.rate_hz + o.imu_time_offset_s <= t_end) {
        write_imu_until(imu_next);
      }
    }
    const LidarScan scan = lidar_sim.scan(k, tr.t_begin(), &labels);
    points += scan.points.size();
    const auto moving = static_cast<std::size_t>(std::count(labels.begin(), labels.end(), std::uint8_t{1}));
    moving_points += moving;
    scans_with_moving += moving > 0;
    if (!scan.points.empty())
      scan_fraction_sum += static_cast<double>(moving) / static_cast<double>(scan.points.size());
    output.write(scan, tr);
    label_file.write(scan.t_end, labels);
    scan_ends.push_back(to_pose(tr.state(scan.t_end)));
    if (scan.t_end - tr.t_begin() >= next_progress) {
      log->info("simulated {:.0f} / {:.0f} s ({:.1f} s wall)", scan.t_end - tr.t_begin(), duration,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
      next_progress += kProgressPeriodS;
    }
  }
  write_imu_until(n_imu - 1);
  output.close(scan_ends);
  label_file.close();
  eval::write_tum((std::filesystem::path(o.out_dir) / "groundtruth.tum").string(), groundtruth);
  const RunFacts facts{n_scans,     n_imu,         points,           duration,
                       full,        path_length,   travelled,        moving_points,
                       scans_with_moving, scan_fraction_sum / static_cast<double>(n_scans)};
  write_scenario_yaml((std::filesystem::path(o.out_dir) / "scenario.yaml").string(), o, sc, lidar, imu_cfg, imu,
                      T_imu_lidar, facts);

  SimSummary summary;
  summary.scans = n_scans;
  summary.imu_samples = n_imu;
  summary.points = points;
  summary.moving_points = moving_points;
  summary.duration_s = duration;
  summary.path_length_m = path_length;
  summary.travelled_m = travelled;
  summary.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  log->info("done: {} scans ({:.0f} points/scan), {} IMU samples, travelled {:.2f} m, in {:.1f} s", n_scans,
            static_cast<double>(points) / static_cast<double>(n_scans), n_imu, travelled, summary.wall_time_s);
  if (sc.traffic)
    log->info("moving objects: {} of {} points ({:.2f} %), in {} of {} scans", moving_points, points,
              100.0 * static_cast<double>(moving_points) / static_cast<double>(std::max<std::size_t>(points, 1)),
              scans_with_moving, n_scans);
  return summary;
}

}  // namespace fuse::sim
