// GlobalLocalizer on worlds whose truth is known: a walled hall sampled as points, with or without
// pillars that break its symmetry; the submap is what lies within range of a known sensor pose,
// given relative to the sensor in a frame turned by an unknown heading.
#include "fuse/estimation/global_localizer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fuse {
namespace {

struct Box {
  Eigen::Vector3d lo, hi;
};

/// The surface of an axis-aligned box sampled every `step` metres.
void sample_box_surface(const Box& b, double step, std::vector<Eigen::Vector3f>& out) {
  for (double x = b.lo.x(); x <= b.hi.x() + 1e-9; x += step)
    for (double y = b.lo.y(); y <= b.hi.y() + 1e-9; y += step)
      for (double z = b.lo.z(); z <= b.hi.z() + 1e-9; z += step) {
        const bool on = std::abs(x - b.lo.x()) < 1e-9 || std::abs(x - b.hi.x()) < step * 0.999 ||
                        std::abs(y - b.lo.y()) < 1e-9 || std::abs(y - b.hi.y()) < step * 0.999 ||
                        std::abs(z - b.lo.z()) < 1e-9 || std::abs(z - b.hi.z()) < step * 0.999;
        if (on) out.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
      }
}

/// A 30 × 16 × 3 m hall (its inside surface) and, optionally, pillars and blocks that make it
/// asymmetric.
std::vector<Eigen::Vector3f> hall(bool pillars, double step = 0.1) {
  std::vector<Eigen::Vector3f> points;
  sample_box_surface({{0, 0, 0}, {30, 16, 3}}, step, points);
  if (pillars) {
    for (const Box& b : {Box{{5, 3, 0}, {5.6, 3.6, 3}}, Box{{12, 11, 0}, {13, 11.5, 3}}, Box{{21, 4, 0}, {21.4, 6, 1.2}},
                         Box{{26, 12, 0}, {27.5, 13, 2}}, Box{{0, 12, 0}, {4, 16, 3}}, Box{{17, 0, 0}, {19, 1.5, 3}}}) {
      sample_box_surface(b, step, points);
    }
  }
  return points;
}

/// The map points within `range` of the sensor at (p, ψ), as the sensor sees them: relative to it
/// and turned by −ψ (so that the search should find (p, ψ)), with noise of σ metres.
std::vector<Eigen::Vector3f> submap_at(const std::vector<Eigen::Vector3f>& world, const Eigen::Vector3d& p, double yaw,
                                       double range, double sigma = 0.01) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, sigma);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector3f> out;
  for (const Eigen::Vector3f& w : world) {
    const Eigen::Vector3d d = w.cast<double>() - p;
    if (d.norm() > range) continue;
    const Eigen::Vector3d q = R * d + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    out.push_back(q.cast<float>());
  }
  return out;
}

double heading_error(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * M_PI)); }

TEST(GlobalLocalizer, FindsThePoseWithoutAGuessInAnAsymmetricHall) {
  const std::vector<Eigen::Vector3f> world = hall(true);
  const GlobalLocalizer localizer(GlobalLocalizationConfig{}, world);
  for (const auto& [p, yaw] : {std::pair{Eigen::Vector3d(8, 6, 1.4), 0.7}, std::pair{Eigen::Vector3d(23, 9, 1.2), -2.5},
                               std::pair{Eigen::Vector3d(15, 4, 1.6), 3.0}}) {
    const GlobalSearchResult r = localizer.search(submap_at(world, p, yaw, 20.0));
    SCOPED_TRACE(r.describe());
    ASSERT_EQ(r.verdict, GlobalSearchResult::Verdict::kLocalized);
    EXPECT_LT((r.best.position - p).norm(), 0.05);
    EXPECT_LT(heading_error(r.best.yaw, yaw), 0.5 * M_PI / 180.0);
    EXPECT_GT(r.best.fit, 0.9);
  }
}

TEST(GlobalLocalizer, ASymmetricHallIsAmbiguousNeverLocalized) {
  // Without pillars the hall looks the same turned by 180° about its centre: two poses fit.
  const std::vector<Eigen::Vector3f> world = hall(false);
  const GlobalLocalizer localizer(GlobalLocalizationConfig{}, world);
  const GlobalSearchResult r = localizer.search(submap_at(world, Eigen::Vector3d(9, 5, 1.4), 0.4, 40.0));
  SCOPED_TRACE(r.describe());
  EXPECT_EQ(r.verdict, GlobalSearchResult::Verdict::kAmbiguous);
  EXPECT_GE(r.candidates, 2u);
  ASSERT_TRUE(r.rival.has_value());
  // The two are the pose and its image turned by 180° about the hall's centre (15, 8).
  const Eigen::Vector3d mirror(30 - 9, 16 - 5, 1.4);
  const bool best_is_truth = (r.best.position - Eigen::Vector3d(9, 5, 1.4)).norm() < 0.2;
  const Eigen::Vector3d other = best_is_truth ? r.rival->position : r.best.position;
  EXPECT_LT((other - (best_is_truth ? mirror : Eigen::Vector3d(9, 5, 1.4))).norm(), 0.2);
}

TEST(GlobalLocalizer, AWindowAroundAWrongPoseFindsNothing) {
  const std::vector<Eigen::Vector3f> world = hall(true);
  const GlobalLocalizer localizer(GlobalLocalizationConfig{}, world);
  const std::vector<Eigen::Vector3f> submap = submap_at(world, Eigen::Vector3d(8, 6, 1.4), 0.7, 20.0);
  SearchWindow wrong;  // 2 m and 30° off, σ of 0.3 m and 3°: the truth is outside
  wrong.center = Eigen::Vector3d(10, 6, 1.4);
  wrong.radius_xy = 0.9;
  wrong.radius_z = 0.3;
  wrong.yaw = 0.7 + 30.0 * M_PI / 180.0;
  wrong.yaw_range = 9.0 * M_PI / 180.0;
  const GlobalSearchResult r = localizer.search(submap, wrong);
  SCOPED_TRACE(r.describe());
  EXPECT_EQ(r.verdict, GlobalSearchResult::Verdict::kNotFound);
  SearchWindow right = wrong;  // and one around a pose 0.5 m and 5° off, which holds the truth
  right.center = Eigen::Vector3d(8.4, 6.3, 1.4);
  right.yaw = 0.7 + 5.0 * M_PI / 180.0;
  right.radius_xy = 1.5;
  right.yaw_range = 15.0 * M_PI / 180.0;
  const GlobalSearchResult q = localizer.search(submap, right);
  SCOPED_TRACE(q.describe());
  ASSERT_EQ(q.verdict, GlobalSearchResult::Verdict::kLocalized);
  EXPECT_LT((q.best.position - Eigen::Vector3d(8, 6, 1.4)).norm(), 0.05);
}

TEST(GlobalLocalizer, BranchAndBoundFindsTheBestGridScoreOfABruteForceSearch) {
  // Oracle: every lattice translation and heading of the search, scored one by one.
  GlobalLocalizationConfig c;
  c.resolution = 0.5;
  c.levels = 3;
  c.max_candidates = 1;
  const std::vector<Eigen::Vector3f> world = hall(true, 0.2);
  const GlobalLocalizer localizer(c, world);
  const std::vector<Eigen::Vector3f> submap = submap_at(world, Eigen::Vector3d(20, 9, 1.3), 1.1, 6.0, 0.02);
  SearchWindow w;
  w.center = Eigen::Vector3d(18, 8, 1.5);
  w.radius_xy = 4.0;
  w.radius_z = 1.0;
  w.yaw = 1.0;
  w.yaw_range = 0.3;
  const GlobalSearchResult r = localizer.search(submap, w);
  double oracle = 0.0;
  const Eigen::Vector3d o = localizer.grid_origin();
  const Eigen::Vector3i lo = ((w.center - Eigen::Vector3d(4, 4, 1) - o) / c.resolution).array().floor().cast<int>();
  const Eigen::Vector3i hi = ((w.center + Eigen::Vector3d(4, 4, 1) - o) / c.resolution).array().ceil().cast<int>();
  double reach = c.resolution;
  for (const Eigen::Vector3f& q : submap) reach = std::max(reach, static_cast<double>(q.head<2>().norm()));
  const double step = 2.0 * c.resolution / reach;
  const int k = static_cast<int>(std::ceil(w.yaw_range / step));
  for (int i = -k; i <= k; ++i)
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) {
          const Eigen::Vector3d t = o + c.resolution * Eigen::Vector3d(x, y, z);
          oracle = std::max(oracle, localizer.score(submap, t, w.yaw + i * step));
        }
  SCOPED_TRACE(r.describe());
  EXPECT_NEAR(r.best_grid_score, oracle, 1e-9);
  EXPECT_GT(r.nodes, 0u);
}

}  // namespace
}  // namespace fuse
