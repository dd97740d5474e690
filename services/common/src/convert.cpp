#include "fuse/service/convert.hpp"

#include "fuse/io/cdr_codec.hpp"

#include <cmath>

namespace fuse::service {

namespace {
fuse_msgs::Vector3 v3(const Eigen::Vector3d& v) {
  fuse_msgs::Vector3 m;
  m.x(v.x());
  m.y(v.y());
  m.z(v.z());
  return m;
}
Eigen::Vector3d v3(const fuse_msgs::Vector3& m) { return {m.x(), m.y(), m.z()}; }

void require(bool ok, const char* reason, const std::string& what) {
  if (!ok) throw InvalidSample(reason, what);
}
Eigen::Vector3d finite_v3(const fuse_msgs::Vector3& m, const char* reason, const char* field) {
  const Eigen::Vector3d v = v3(m);
  require(v.allFinite(), reason, std::string(field) + " is not finite");
  return v;
}
}  // namespace

fuse_msgs::Pose to_pose(const Eigen::Vector3d& p, const Eigen::Matrix3d& R) {
  fuse_msgs::Pose m;
  m.position(v3(p));
  const Eigen::Quaterniond q(R);
  fuse_msgs::Quaternion mq;
  mq.x(q.x());
  mq.y(q.y());
  mq.z(q.z());
  mq.w(q.w());
  m.orientation(mq);
  return m;
}

Eigen::Isometry3d from_pose(const fuse_msgs::Pose& pose) {
  const auto& o = pose.orientation();
  const Eigen::Quaterniond q(o.w(), o.x(), o.y(), o.z());
  require(q.coeffs().allFinite() && std::abs(q.norm() - 1.0) < 1e-3, "bad_pose", "orientation is not a unit quaternion");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = finite_v3(pose.position(), "bad_pose", "position");
  return T;
}

fuse_msgs::ImuSample to_msg(const ImuSample& imu, const std::string& frame) {
  fuse_msgs::ImuSample m;
  m.t(imu.t);
  m.gyro(v3(imu.gyro));
  m.accel(v3(imu.accel));
  m.frame(frame.substr(0, 64));
  return m;
}

ImuSample from_msg(const fuse_msgs::ImuSample& m) {
  ImuSample imu;
  imu.t = m.t();
  require(std::isfinite(imu.t), "imu_not_finite", "IMU time is not finite");
  imu.gyro = finite_v3(m.gyro(), "imu_not_finite", "IMU gyro");
  imu.accel = finite_v3(m.accel(), "imu_not_finite", "IMU accel");
  return imu;
}

fuse_msgs::LidarScan to_msg(const LidarScan& scan, const std::string& frame) {
  fuse_msgs::LidarScan m;
  m.start_time(scan.t_start);
  m.end_time(scan.t_end);
  m.sequence_number(scan.sequence);
  m.frame(frame.substr(0, 64));
  auto& pts = m.points();
  pts.resize(scan.points.size());
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    const LidarPoint& p = scan.points[i];
    pts[i].x(p.x);
    pts[i].y(p.y);
    pts[i].z(p.z);
    pts[i].intensity(p.intensity);
    pts[i].time_offset(p.t_rel);
    pts[i].ring(p.ring);
  }
  return m;
}

LidarScan from_msg(const fuse_msgs::LidarScan& m) {
  LidarScan scan;
  scan.t_start = m.start_time();
  scan.t_end = m.end_time();
  scan.sequence = m.sequence_number();
  scan.points.resize(m.points().size());
  for (std::size_t i = 0; i < m.points().size(); ++i) {
    const auto& p = m.points()[i];
    scan.points[i] = LidarPoint{p.x(), p.y(), p.z(), p.intensity(), p.time_offset(), p.ring()};
  }
  check_scan(scan);
  return scan;
}

void check_scan(const LidarScan& scan) {
  require(std::isfinite(scan.t_start) && std::isfinite(scan.t_end), "scan_bad_time", "scan times are not finite");
  require(scan.t_end >= scan.t_start, "scan_bad_time", "scan ends before it starts");
  require(scan.t_end - scan.t_start <= 1.0, "scan_bad_time", "scan lasts more than 1 s");
  require(!scan.points.empty(), "scan_empty", "scan has no points");
  const double span = scan.t_end - scan.t_start;
  std::size_t bad = 0;
  for (const LidarPoint& q : scan.points) {
    if (!std::isfinite(q.t_rel) || q.t_rel < -1e-3 || q.t_rel > span + 1e-3) ++bad;
  }
  require(bad == 0, "scan_bad_point_time", std::to_string(bad) + " point time offsets are not finite or outside the scan");
}

std::vector<std::uint8_t> scan_to_wire(const LidarScan& scan, const std::string& frame) {
  return io::encode_scan(scan, frame.substr(0, fuse_msgs::MAX_FRAME_ID));
}

fuse_msgs::Correction to_msg(const Posterior& post) {
  fuse_msgs::Correction m;
  m.t(post.t);
  m.scan_sequence(post.scan_sequence);
  m.frame_change(to_pose(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()));
  m.pose(to_pose(post.x.p, post.x.R));
  m.velocity(v3(post.x.v));
  m.extrinsic(to_pose(post.x.p_IL, post.x.R_IL));
  m.gyro_bias(v3(post.x.bg));
  m.accel_bias(v3(post.x.ba));
  m.gravity(v3(post.x.g));
  m.time_offset(post.x.td);
  for (int r = 0; r < kStateDim; ++r) {
    for (int c = 0; c < kStateDim; ++c) m.covariance()[static_cast<std::size_t>(r * kStateDim + c)] = post.P(r, c);
  }
  return m;
}

namespace {
/// Rotation matrices travel as quaternions; the exact matrix is what the estimator computed, so
/// the entry is rebuilt from the quaternion and re-normalised (differences ~1e-16).
Eigen::Matrix3d rotation_of(const fuse_msgs::Pose& pose, const char* reason) {
  const auto& o = pose.orientation();
  const Eigen::Quaterniond q(o.w(), o.x(), o.y(), o.z());
  require(q.coeffs().allFinite() && std::abs(q.norm() - 1.0) < 1e-3, reason, "orientation is not a unit quaternion");
  return q.normalized().toRotationMatrix();
}
}  // namespace

Posterior from_msg(const fuse_msgs::Correction& m) {
  Posterior post;
  post.t = m.t();
  require(std::isfinite(post.t), "correction_invalid", "correction time is not finite");
  post.scan_sequence = m.scan_sequence();
  post.x.p = finite_v3(m.pose().position(), "correction_invalid", "position");
  post.x.R = rotation_of(m.pose(), "correction_invalid");
  post.x.v = finite_v3(m.velocity(), "correction_invalid", "velocity");
  post.x.p_IL = finite_v3(m.extrinsic().position(), "correction_invalid", "extrinsic position");
  post.x.R_IL = rotation_of(m.extrinsic(), "correction_invalid");
  post.x.bg = finite_v3(m.gyro_bias(), "correction_invalid", "gyro bias");
  post.x.ba = finite_v3(m.accel_bias(), "correction_invalid", "accel bias");
  post.x.g = finite_v3(m.gravity(), "correction_invalid", "gravity");
  require(post.x.g.norm() > 1.0, "correction_invalid", "gravity is not a gravity vector");
  post.x.td = m.time_offset();
  require(std::isfinite(post.x.td) && std::abs(post.x.td) <= 1.0, "correction_invalid",
          "time offset is not finite or beyond 1 s");
  for (int r = 0; r < kStateDim; ++r) {
    for (int c = 0; c < kStateDim; ++c) post.P(r, c) = m.covariance()[static_cast<std::size_t>(r * kStateDim + c)];
  }
  require(post.P.allFinite(), "correction_invalid", "covariance is not finite");
  require((post.P.diagonal().array() >= 0.0).all(), "correction_invalid", "covariance has a negative variance");
  return post;
}

const char* to_string(fuse_msgs::MapFrame state) {
  switch (state) {
    case fuse_msgs::MAP_FRAME_UNDECIDED: return "undecided";
    case fuse_msgs::MAP_FRAME_OWN: return "own";
    case fuse_msgs::MAP_FRAME_SEARCHING: return "searching";
    case fuse_msgs::MAP_FRAME_CONFIRMING: return "confirming";
    case fuse_msgs::MAP_FRAME_LOCALIZED: return "localized";
  }
  return "unknown";
}

bool valid(fuse_msgs::MapFrame state) {
  const auto v = static_cast<long long>(state);
  return v >= static_cast<long long>(fuse_msgs::MAP_FRAME_UNDECIDED) && v <= static_cast<long long>(fuse_msgs::MAP_FRAME_LOCALIZED);
}

WorldFrame frame_of(const fuse_msgs::Correction& m) {
  require(valid(m.map_frame()), "correction_invalid",
          "unknown map frame state " + std::to_string(static_cast<long long>(m.map_frame())));
  return WorldFrame{m.map_frame(), m.frame_epoch()};
}

Eigen::Isometry3d frame_change_of(const fuse_msgs::Correction& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = finite_v3(m.frame_change().position(), "correction_invalid", "frame change position");
  T.linear() = rotation_of(m.frame_change(), "correction_invalid");
  return T;
}

fuse_msgs::HistoryEntry to_msg(const StateHistory::Entry& e) {
  fuse_msgs::HistoryEntry m;
  m.t(e.t);
  m.pose(to_pose(e.x.p, e.x.R));
  m.velocity(v3(e.x.v));
  m.extrinsic(to_pose(e.x.p_IL, e.x.R_IL));
  m.gyro_bias(v3(e.x.bg));
  m.accel_bias(v3(e.x.ba));
  m.gravity(v3(e.x.g));
  m.time_offset(e.x.td);
  m.gyro(v3(e.gyro));
  m.accel(v3(e.accel));
  m.gyro_smooth(v3(e.gyro_smooth));
  m.coasting(e.coasting);
  if (!e.step.empty()) {
    m.step_q().assign(e.step.q.data(), e.step.q.data() + kStateDim);
    m.step_level_accel(v3(e.step.level_accel));
    m.step_level_sigma(e.step.level_sigma);
    m.step_coast_from(e.step.coast_from);
    m.step_coast_accel_std(e.step.coast_accel_std);
    m.step_coast_gyro_std(e.step.coast_gyro_std);
  }
  return m;
}

StateHistory::Entry from_msg(const fuse_msgs::HistoryEntry& m) {
  StateHistory::Entry e;
  e.t = m.t();
  require(std::isfinite(e.t), "history_invalid", "history entry time is not finite");
  e.x.p = finite_v3(m.pose().position(), "history_invalid", "position");
  e.x.R = rotation_of(m.pose(), "history_invalid");
  e.x.v = finite_v3(m.velocity(), "history_invalid", "velocity");
  e.x.p_IL = finite_v3(m.extrinsic().position(), "history_invalid", "extrinsic position");
  e.x.R_IL = rotation_of(m.extrinsic(), "history_invalid");
  e.x.bg = finite_v3(m.gyro_bias(), "history_invalid", "gyro bias");
  e.x.ba = finite_v3(m.accel_bias(), "history_invalid", "accel bias");
  e.x.g = finite_v3(m.gravity(), "history_invalid", "gravity");
  e.x.td = m.time_offset();
  require(std::isfinite(e.x.td) && std::abs(e.x.td) <= 1.0, "history_invalid", "time offset is not finite or beyond 1 s");
  e.gyro = finite_v3(m.gyro(), "history_invalid", "gyro");
  e.accel = finite_v3(m.accel(), "history_invalid", "accel");
  e.gyro_smooth = finite_v3(m.gyro_smooth(), "history_invalid", "smoothed gyro");
  e.P = StateCovariance::Zero();
  e.coasting = m.coasting();
  if (!m.step_q().empty()) {
    require(m.step_q().size() == static_cast<std::size_t>(kStateDim), "history_invalid",
            "entry step covariance has " + std::to_string(m.step_q().size()) + " values, not " + std::to_string(kStateDim));
    for (int i = 0; i < kStateDim; ++i) e.step.q(i) = m.step_q()[static_cast<std::size_t>(i)];
    require(e.step.q.allFinite() && (e.step.q.array() >= 0.0).all(), "history_invalid",
            "entry step covariance is not a finite variance");
  }
  e.step.level_accel = finite_v3(m.step_level_accel(), "history_invalid", "step levelling accel");
  e.step.level_sigma = m.step_level_sigma();
  require(std::isfinite(e.step.level_sigma) && e.step.level_sigma >= 0.0, "history_invalid",
          "step levelling sigma is not a finite non-negative angle");
  e.step.coast_from = m.step_coast_from();
  e.step.coast_accel_std = m.step_coast_accel_std();
  e.step.coast_gyro_std = m.step_coast_gyro_std();
  require(std::isfinite(e.step.coast_from) && std::isfinite(e.step.coast_accel_std) && e.step.coast_accel_std >= 0.0 &&
              std::isfinite(e.step.coast_gyro_std) && e.step.coast_gyro_std >= 0.0,
          "history_invalid", "step coast is not a finite time and non-negative deviations");
  require(!e.step.coasts() || e.step.coast_from <= e.t, "history_invalid", "step coast starts after its entry");
  return e;
}

fuse_msgs::StateEstimate to_estimate(const StateQuery& q, std::uint64_t sequence) {
  fuse_msgs::StateEstimate m;
  m.t(q.t);
  m.sequence_number(sequence);
  m.frame("world");
  m.child_frame("imu");
  switch (q.status) {
    case QueryStatus::kNotInitialised: m.status(fuse_msgs::STATUS_NOT_INITIALISED); return m;
    case QueryStatus::kTooOld: m.status(fuse_msgs::STATUS_TOO_OLD); return m;
    case QueryStatus::kInFuture: m.status(fuse_msgs::STATUS_IN_FUTURE); return m;
    case QueryStatus::kCorrected: m.status(fuse_msgs::STATUS_INTERPOLATED); break;
    case QueryStatus::kPropagated: m.status(fuse_msgs::STATUS_PROPAGATED); break;
  }
  m.pose(to_pose(q.x.p, q.x.R));
  m.velocity(v3(q.x.v));
  m.gyro_bias(v3(q.x.bg));
  m.accel_bias(v3(q.x.ba));
  m.gravity(v3(q.x.g));
  m.angular_velocity(v3(q.omega));
  // Pose covariance in the order (position, rotation): the error state's kPos and kRot blocks.
  const int idx[6] = {Idx::kPos, Idx::kPos + 1, Idx::kPos + 2, Idx::kRot, Idx::kRot + 1, Idx::kRot + 2};
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m.pose_covariance()[static_cast<std::size_t>(r * 6 + c)] = q.P(idx[r], idx[c]);
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.velocity_covariance()[static_cast<std::size_t>(r * 3 + c)] = q.P(Idx::kVel + r, Idx::kVel + c);
  }
  return m;
}

}  // namespace fuse::service
