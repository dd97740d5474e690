#include "fuse/sim/lidar_model.hpp"

#include <algorithm>
#include <cmath>

namespace fuse::sim {

namespace {
constexpr double kIntensityFloor = 0.25;   // share of the intensity independent of incidence
constexpr double kIntensityScale = 255.0;  // 8-bit intensity scale
}  // namespace

LidarSimulator::LidarSimulator(const LidarConfig& config, const World& world, const Trajectory& trajectory,
                               const Eigen::Isometry3d& T_imu_lidar, std::uint64_t seed, const Traffic* traffic)
    : config_(config),
      world_(world),
      trajectory_(trajectory),
      T_imu_lidar_(T_imu_lidar),
      rng_(seed, Stream::kLidar),
      traffic_(traffic) {}

fuse::LidarScan LidarSimulator::scan(std::uint64_t frame_index, double t0, std::vector<std::uint8_t>* labels) {
  fuse::LidarScan out;
  const double t_start = t0 + static_cast<double>(frame_index) * config_.frame_period_s;
  out.t_start = t_start;
  out.t_end = t0 + static_cast<double>(frame_index + 1) * config_.frame_period_s;
  out.sequence = frame_index;
  generate_shots(config_, frame_index, shots_);
  out.points.reserve(shots_.size());
  if (labels) {
    labels->clear();
    labels->reserve(shots_.size());
  }
  const Eigen::Matrix3d R_il = T_imu_lidar_.linear();
  const Eigen::Vector3d t_il = T_imu_lidar_.translation();
  candidates_.clear();
  if (traffic_) {
    // The movers that can be within range during this frame: around the middle of the sensor's
    // path over the frame, the range plus half of that path.
    const Eigen::Vector3d a = trajectory_.state(out.t_start).p, b = trajectory_.state(out.t_end).p;
    const double reach = config_.max_range_m + 0.5 * (b - a).norm() + t_il.norm();
    traffic_->candidates(out.t_start, out.t_end, 0.5 * (a + b), reach, candidates_);
  }
  TrajectoryState s;
  float state_t_rel = -1.f;  // the state is shared by the shots fired together (a spinning column)
  for (const Shot& shot : shots_) {
    // The ray is cast at exactly the recorded time t_start + t_rel (t_rel as stored, float).
    const double t_shot = t_start + static_cast<double>(shot.t_rel);
    if (shot.t_rel != state_t_rel) {
      s = trajectory_.state(t_shot);
      state_t_rel = shot.t_rel;
    }
    const Eigen::Vector3d origin = s.p + s.R * t_il;
    Eigen::Vector3d dir_l = shot.dir;
    if (config_.angular_noise_sigma_rad > 0.0) {
      const double d_az = rng_.normal(config_.angular_noise_sigma_rad);
      const double d_el = rng_.normal(config_.angular_noise_sigma_rad);
      dir_l = direction(shot.azimuth + d_az, shot.elevation + d_el);
    }
    const double range_noise = rng_.normal(config_.range_noise_sigma_m);  // drawn for every shot
    const Eigen::Vector3d dir_w = s.R * (R_il * dir_l);
    Hit hit = world_.cast(origin, dir_w, config_.max_range_m);
    bool moving = false;
    if (!candidates_.empty()) {
      const Hit mover = traffic_->cast(candidates_, origin, dir_w, std::min(config_.max_range_m, hit.range), t_shot);
      if (mover.range < hit.range) {
        hit = mover;
        moving = true;
      }
    }
    if (!hit.valid() || hit.range < config_.blind_range_m) continue;
    const double measured = hit.range + range_noise;
    if (measured < config_.blind_range_m || measured > config_.max_range_m) continue;
    const Eigen::Vector3d p = measured * shot.dir;
    const double cos_inc = std::abs(hit.normal.dot(dir_w));
    fuse::LidarPoint pt;
    pt.x = static_cast<float>(p.x());
    pt.y = static_cast<float>(p.y());
    pt.z = static_cast<float>(p.z());
    pt.intensity = static_cast<float>(std::round(
        kIntensityScale * hit.material.reflectivity * (kIntensityFloor + (1.0 - kIntensityFloor) * cos_inc)));
    pt.t_rel = shot.t_rel;
    pt.ring = shot.ring;
    out.points.push_back(pt);
    if (labels) labels->push_back(moving ? 1 : 0);
  }
  return out;
}

}  // namespace fuse::sim
