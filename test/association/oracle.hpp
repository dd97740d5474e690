// Brute-force references for the association tests.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <random>
#include <vector>

namespace fuse::test {

/// The squared distances of the k nearest points within max_dist of q, ascending (exhaustive).
inline std::vector<float> brute_force_knn(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& q, int k,
                                          float max_dist) {
  std::vector<float> d2;
  for (const Eigen::Vector3f& p : points) {
    const float d = (p - q).squaredNorm();
    if (d <= max_dist * max_dist) d2.push_back(d);
  }
  std::sort(d2.begin(), d2.end());
  if (d2.size() > static_cast<std::size_t>(k)) d2.resize(static_cast<std::size_t>(k));
  return d2;
}

/// Uniform random points in the cube [−half, half]³.
inline std::vector<Eigen::Vector3f> random_cloud(std::mt19937& rng, int n, float half) {
  std::uniform_real_distribution<float> u(-half, half);
  std::vector<Eigen::Vector3f> out;
  out.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out.emplace_back(u(rng), u(rng), u(rng));
  return out;
}

}  // namespace fuse::test
