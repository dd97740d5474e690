// TUM and KITTI trajectory files with line-by-line validation.
#include "fuse/eval/trajectory.hpp"

#include <Eigen/SVD>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse::eval {
namespace {

constexpr int kTumColumns = 8;     // t x y z qx qy qz qw
constexpr int kKittiColumns = 12;  // 3x4 row-major [R | t]
constexpr int kTumPrecision = 9;   // decimals of time and position written by write_tum

/// "file:line: what" for every reader error.
[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& what) {
  throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
}

std::ifstream open_input(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open trajectory file for reading");
  return in;
}

/// True for lines that carry no data: empty, whitespace or a '#' comment.
bool is_blank_or_comment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

/// Splits a line into finite numbers; exactly `columns` of them or an error naming the line.
std::vector<double> parse_numbers(const std::string& line, int columns, const std::string& path,
                                  std::size_t line_no) {
  std::istringstream tokens(line);
  std::vector<double> values;
  std::string token;
  while (tokens >> token) {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') fail(path, line_no, "'" + token + "' is not a number");
    if (errno == ERANGE || !std::isfinite(value)) fail(path, line_no, "'" + token + "' is not a finite number");
    values.push_back(value);
  }
  if (static_cast<int>(values.size()) != columns) {
    fail(path, line_no, "expected " + std::to_string(columns) + " columns, found " + std::to_string(values.size()));
  }
  return values;
}

/// TUM quaternion (qx qy qz qw), normalised when close to unit norm.
Eigen::Quaterniond unit_quaternion(double x, double y, double z, double w, const std::string& path,
                                   std::size_t line_no) {
  Eigen::Quaterniond q(w, x, y, z);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kUnitQuaternionTolerance) {
    fail(path, line_no, "quaternion is not unit (norm " + std::to_string(norm) + ")");
  }
  q.coeffs() /= norm;
  return q;
}

/// KITTI rotation block checked for orthonormality and projected onto SO(3) (nearest rotation).
Eigen::Quaterniond rotation_from_matrix(const Eigen::Matrix3d& R, const std::string& path, std::size_t line_no) {
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (orthogonality > kRotationTolerance || std::abs(det - 1.0) > kRotationTolerance) {
    fail(path, line_no,
         "rotation block is not a rotation (max |R^T R - I| " + std::to_string(orthogonality) + ", det " +
             std::to_string(det) + ")");
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d nearest = svd.matrixU() * svd.matrixV().transpose();
  return Eigen::Quaterniond(nearest).normalized();
}

/// Reads the optional KITTI times file: one finite, increasing stamp per line.
std::vector<double> read_times(const std::string& path) {
  std::ifstream in = open_input(path);
  std::vector<double> times;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (is_blank_or_comment(line)) continue;
    const double t = parse_numbers(line, 1, path, line_no)[0];
    if (!times.empty() && t <= times.back()) fail(path, line_no, "timestamp " + std::to_string(t) + " is not increasing");
    times.push_back(t);
  }
  return times;
}

}  // namespace

Trajectory read_tum(const std::string& path) {
  std::ifstream in = open_input(path);
  Trajectory trajectory;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (is_blank_or_comment(line)) continue;
    const std::vector<double> v = parse_numbers(line, kTumColumns, path, line_no);
    StampedPose pose;
    pose.t = v[0];
    pose.p = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.q = unit_quaternion(v[4], v[5], v[6], v[7], path, line_no);
    if (!trajectory.empty() && pose.t < trajectory.back().t) {
      fail(path, line_no, "timestamp " + std::to_string(pose.t) + " is before the previous one");
    }
    if (!trajectory.empty() && pose.t == trajectory.back().t) {
      logger("eval")->warn("{}:{}: repeated timestamp {:.9f}; keeping the first pose", path, line_no, pose.t);
      continue;
    }
    trajectory.push_back(pose);
  }
  if (trajectory.empty()) throw std::runtime_error(path + ": contains no poses");
  return trajectory;
}

Trajectory read_kitti(const std::string& path, const std::string& times_path) {
  std::ifstream in = open_input(path);
  Trajectory trajectory;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (is_blank_or_comment(line)) continue;
    const std::vector<double> v = parse_numbers(line, kKittiColumns, path, line_no);
    Eigen::Matrix3d R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    StampedPose pose;
    pose.t = static_cast<double>(trajectory.size());
    pose.p = Eigen::Vector3d(v[3], v[7], v[11]);
    pose.q = rotation_from_matrix(R, path, line_no);
    trajectory.push_back(pose);
  }
  if (trajectory.empty()) throw std::runtime_error(path + ": contains no poses");
  if (times_path.empty()) return trajectory;

  const std::vector<double> times = read_times(times_path);
  if (times.size() != trajectory.size()) {
    throw std::runtime_error(times_path + ": has " + std::to_string(times.size()) + " timestamps but " + path +
                             " has " + std::to_string(trajectory.size()) + " poses");
  }
  for (std::size_t i = 0; i < times.size(); ++i) trajectory[i].t = times[i];
  return trajectory;
}

void write_tum(const std::string& path, const Trajectory& trajectory) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open trajectory file for writing");
  out << "# timestamp tx ty tz qx qy qz qw\n" << std::fixed << std::setprecision(kTumPrecision);
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const StampedPose& pose = trajectory[i];
    if (!std::isfinite(pose.t) || !pose.p.allFinite() || !pose.q.coeffs().allFinite() || pose.q.norm() == 0.0) {
      throw std::runtime_error(path + ": pose " + std::to_string(i) + " has non-finite values; not written");
    }
    const Eigen::Quaterniond q = pose.q.normalized();
    out << pose.t << ' ' << pose.p.x() << ' ' << pose.p.y() << ' ' << pose.p.z() << ' ' << q.x() << ' ' << q.y()
        << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  out.flush();
  if (!out) throw std::runtime_error(path + ": write failed");
}

TrajectoryFormat parse_trajectory_format(const std::string& name) {
  if (name == "tum") return TrajectoryFormat::kTum;
  if (name == "kitti") return TrajectoryFormat::kKitti;
  throw std::invalid_argument("unknown trajectory format '" + name + "' (expected tum or kitti)");
}

Trajectory read_trajectory(const std::string& path, TrajectoryFormat format) {
  return format == TrajectoryFormat::kTum ? read_tum(path) : read_kitti(path);
}

}  // namespace fuse::eval
