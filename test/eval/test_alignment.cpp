// Umeyama recovers a known SE(3) / Sim(3) exactly from transformed points.
#include <gtest/gtest.h>

#include <cstdlib>

#include "fuse/eval/alignment.hpp"

namespace fuse::eval {
namespace {

constexpr int kPoints = 50;
constexpr int kTrials = 20;

Similarity3 random_similarity(bool with_scale) {
  Similarity3 T;
  T.rotation = Eigen::Quaterniond(Eigen::Vector4d::Random()).normalized().toRotationMatrix();
  T.translation = 10.0 * Eigen::Vector3d::Random();
  T.scale = with_scale ? 0.2 + 3.0 * std::abs(Eigen::Vector2d::Random().x()) : 1.0;
  return T;
}

Eigen::Matrix3Xd apply(const Similarity3& T, const Eigen::Matrix3Xd& x) {
  Eigen::Matrix3Xd y(3, x.cols());
  for (Eigen::Index i = 0; i < x.cols(); ++i) y.col(i) = T(x.col(i));
  return y;
}

void expect_recovers(bool with_scale) {
  std::srand(42);  // Eigen's Random uses std::rand: fixed seed, reproducible
  for (int trial = 0; trial < kTrials; ++trial) {
    const Eigen::Matrix3Xd x = 5.0 * Eigen::Matrix3Xd::Random(3, kPoints);
    const Similarity3 truth = random_similarity(with_scale);
    const Similarity3 T = umeyama_alignment(x, apply(truth, x), with_scale);
    EXPECT_LT((T.rotation - truth.rotation).norm(), 1e-9) << "trial " << trial;
    EXPECT_LT((T.translation - truth.translation).norm(), 1e-8) << "trial " << trial;
    EXPECT_NEAR(T.scale, truth.scale, 1e-9) << "trial " << trial;
    EXPECT_NEAR(T.rotation.determinant(), 1.0, 1e-12);
  }
}

TEST(Alignment, UmeyamaRecoversRandomSE3) { expect_recovers(false); }
TEST(Alignment, UmeyamaRecoversRandomSim3) { expect_recovers(true); }

TEST(Alignment, PlanarPointsGiveAProperRotation) {
  // Coplanar points (rank-2 covariance) still determine the rotation; it must not be a reflection.
  std::srand(7);
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Random(3, kPoints);
  x.row(2).setZero();
  const Similarity3 truth = random_similarity(true);
  const Similarity3 T = umeyama_alignment(x, apply(truth, x), true);
  EXPECT_NEAR(T.rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((T.rotation - truth.rotation).norm(), 1e-9);
  EXPECT_NEAR(T.scale, truth.scale, 1e-9);
}

TEST(Alignment, RejectsDegenerateInput) {
  Eigen::Matrix3Xd line(3, 4);
  line << 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3;
  EXPECT_THROW(umeyama_alignment(line, line, false), std::invalid_argument);
  EXPECT_THROW(umeyama_alignment(Eigen::Matrix3Xd::Random(3, 2), Eigen::Matrix3Xd::Random(3, 2), false), std::invalid_argument);
  EXPECT_THROW(umeyama_alignment(Eigen::Matrix3Xd::Random(3, 5), Eigen::Matrix3Xd::Random(3, 4), false), std::invalid_argument);
}

TEST(Alignment, AlignAndTransformTrajectories) {
  std::srand(3);
  const Similarity3 truth = random_similarity(true);
  Trajectory ref;
  for (int i = 0; i < kPoints; ++i) {
    StampedPose pose;
    pose.t = i;
    pose.p = 4.0 * Eigen::Vector3d::Random();
    pose.q = Eigen::Quaterniond(Eigen::Vector4d::Random()).normalized();
    ref.push_back(pose);
  }
  // est = truth⁻¹ applied to ref, so align(ref, est) must give back truth.
  Similarity3 inverse;
  inverse.rotation = truth.rotation.transpose();
  inverse.scale = 1.0 / truth.scale;
  inverse.translation = -inverse.scale * inverse.rotation * truth.translation;
  const Trajectory est = transform(ref, inverse);
  const Similarity3 T = align(ref, est, AlignmentMode::kSim3);
  EXPECT_NEAR(T.scale, truth.scale, 1e-9);
  const Trajectory back = transform(est, T);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_LT((back[i].p - ref[i].p).norm(), 1e-9);
    EXPECT_LT(back[i].q.angularDistance(ref[i].q), 1e-9);
  }
  EXPECT_TRUE(align(ref, est, AlignmentMode::kNone).rotation.isIdentity());
  EXPECT_EQ(align(ref, est, AlignmentMode::kSE3).scale, 1.0);
  EXPECT_EQ(parse_alignment_mode("sim3"), AlignmentMode::kSim3);
  EXPECT_THROW(parse_alignment_mode("sim2"), std::invalid_argument);
}

}  // namespace
}  // namespace fuse::eval
