// Helpers shared by the evaluation tests: temporary files and synthetic trajectories.
#pragma once

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <string>

#include "fuse/eval/trajectory.hpp"

namespace fuse::eval::test {

/// A file in the system temp directory, removed when the object goes away.
class TempFile {
 public:
  explicit TempFile(const std::string& content, const std::string& suffix = ".txt") {
    static std::atomic<int> counter{0};
    path_ = (std::filesystem::temp_directory_path() /
             ("fuse_eval_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + suffix))
                .string();
    std::ofstream(path_) << content;
  }
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// A closed circle of radius r in the xy plane, heading along the tangent, n poses at 10 Hz;
/// the last pose is back at the start.
inline Trajectory circle(double radius, int n) {
  Trajectory out;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / (n - 1);
    StampedPose pose;
    pose.t = 0.1 * i;
    pose.p = Eigen::Vector3d(radius * std::cos(a), radius * std::sin(a), 0.0);
    pose.q = Eigen::Quaterniond(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ()));
    out.push_back(pose);
  }
  return out;
}

}  // namespace fuse::eval::test
