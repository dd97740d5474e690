// smallest_eigen (smallest_eigen.hpp) against Eigen's iterative solver in double, the oracle, over
// the scatter matrices a plane fit meets: noisy patches, exact planes, lines, blobs, rings.
#include "fuse/association/smallest_eigen.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include <vector>

namespace fuse {
namespace {

Eigen::Matrix3f scatter(const std::vector<Eigen::Vector3f>& pts) {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<float>(pts.size());
  Eigen::Matrix3f C = Eigen::Matrix3f::Zero();
  for (const auto& p : pts) C += (p - mean) * (p - mean).transpose();
  return C;
}

/// Five points (the association's neighbourhood) spread by `extent` along three random
/// orthogonal axes, at a random place up to 50 m from the origin.
std::vector<Eigen::Vector3f> cloud(std::mt19937& rng, const Eigen::Vector3f& extent, int n = 5) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::uniform_real_distribution<float> far(-50.0f, 50.0f);
  const Eigen::Matrix3f R = Eigen::Quaternionf(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
  const Eigen::Vector3f at(far(rng), far(rng), far(rng));
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < n; ++i) pts.push_back(at + R * Eigen::Vector3f(g(rng), g(rng), g(rng)).cwiseProduct(extent));
  return pts;
}

void expect_matches_oracle(const Eigen::Matrix3f& C) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> oracle(C.cast<double>());
  const SmallestEigen got = smallest_eigen(C);
  const double scale = C.trace();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got.values(i), oracle.eigenvalues()(i), 1e-5 * scale) << "eigenvalue " << i;
  EXPECT_NEAR(got.vector.norm(), 1.0f, 1e-5f);
  // The vector is defined (up to sign) where λ₀ stands apart from λ₁; its error is the matrix's
  // rounding over that gap.
  const double gap = oracle.eigenvalues()(1) - oracle.eigenvalues()(0);
  if (gap > 1e-3 * scale) {
    const double cos = std::abs(got.vector.cast<double>().dot(oracle.eigenvectors().col(0)));
    EXPECT_GT(cos, 1.0 - 1e-6) << "gap " << gap / scale << " of tr C";
  }
  // Whatever the gap, it is an eigenvector of the smallest eigenvalue to the matrix's precision.
  const Eigen::Vector3d v = got.vector.cast<double>();
  EXPECT_LT((C.cast<double>() * v - oracle.eigenvalues()(0) * v).norm(), 1e-4 * scale);
}

TEST(SmallestEigen, MatchesTheOracleOnPlanarPatches) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> thick(1e-4f, 0.05f);
  for (int i = 0; i < 2000; ++i) expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.3f, thick(rng)})));
}

TEST(SmallestEigen, MatchesTheOracleOnExactPlanes) {
  std::mt19937 rng(8);
  for (int i = 0; i < 200; ++i) expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.3f, 0.0f})));
}

TEST(SmallestEigen, MatchesTheOracleOnLinesBlobsAndRings) {
  std::mt19937 rng(9);
  for (int i = 0; i < 300; ++i) {
    expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.01f, 0.01f})));   // along a line
    expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.0f, 0.0f})));     // exactly a line
    expect_matches_oracle(scatter(cloud(rng, {0.3f, 0.3f, 0.3f})));     // a blob
    expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.02f, 0.002f})));  // a ring's arc
    expect_matches_oracle(scatter(cloud(rng, {0.5f, 0.5f, 0.0001f}, 16)));
  }
}

TEST(SmallestEigen, HandlesTheDegenerateMatrices) {
  const SmallestEigen zero = smallest_eigen(Eigen::Matrix3f::Zero());
  EXPECT_NEAR(zero.vector.norm(), 1.0f, 1e-6f);
  EXPECT_EQ(zero.values, Eigen::Vector3f::Zero());
  expect_matches_oracle(Eigen::Vector3f(1.0f, 1.0f, 1.0f).asDiagonal());
  expect_matches_oracle(Eigen::Vector3f(0.0f, 2.0f, 1.0f).asDiagonal());
  expect_matches_oracle(Eigen::Vector3f(3.0f, 2.0f, 1.0f).asDiagonal());
}

}  // namespace
}  // namespace fuse
