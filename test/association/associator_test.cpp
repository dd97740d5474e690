// Plane fitting and point-to-plane association (associator.hpp) against a known plane map.
#include "fuse/association/associator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "fuse/association/spatial_index.hpp"
#include "oracle.hpp"

namespace fuse {
namespace {


Eigen::Vector3f plane_point(const Eigen::Vector3f& n, float d, float u, float v) {
  // Two directions spanning the plane nᵀx + d = 0, and its point closest to the origin.
  const Eigen::Vector3f a = n.unitOrthogonal(), b = n.cross(a);
  return -d * n + u * a + v * b;
}

TEST(FitPlane, RecoversNormalAndOffsetFromNoisyPoints) {
  std::mt19937 rng(100);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  const Eigen::Vector3f n = Eigen::Vector3f(0.3f, -0.5f, 0.8f).normalized();
  constexpr float kD = -2.0f;
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 10; ++i) pts.push_back(plane_point(n, kD, u(rng), u(rng)) + noise(rng) * n);
  Eigen::Vector3f normal;
  float d = 0.f;
  ASSERT_TRUE(fit_plane(pts.data(), static_cast<int>(pts.size()), 0.05f, normal, d));
  EXPECT_NEAR(normal.norm(), 1.0f, 1e-5f);
  const float sign = normal.dot(n) > 0 ? 1.0f : -1.0f;  // the sign of a plane normal is arbitrary
  EXPECT_LT(std::acos(std::min(1.0f, sign * normal.dot(n))), 0.05f);  // ~σ/extent
  EXPECT_NEAR(sign * d, kD, 0.01f);
}

// A "ramp" fitted through two parallel surfaces 8 cm apart (a step) reports an RMS of about half
// the offset, while points on one surface report ~0: the model down-weights such fits by it.
TEST(FitPlane, ReportsTheRmsDistanceToThePlane) {
  std::vector<Eigen::Vector3f> flat, step;
  for (int i = 0; i < 8; ++i) {
    const float x = 0.1f * static_cast<float>(i);
    flat.emplace_back(x, 0.05f * static_cast<float>(i % 3), 1.0f);
    step.emplace_back(x, 0.05f * static_cast<float>(i % 3), i < 4 ? 1.0f : 1.08f);
  }
  Eigen::Vector3f normal;
  float d = 0.f, rms = -1.f;
  ASSERT_TRUE(fit_plane(flat.data(), 8, 0.1f, normal, d, &rms));
  EXPECT_NEAR(rms, 0.0f, 1e-4f);
  ASSERT_TRUE(fit_plane(step.data(), 8, 0.1f, normal, d, &rms));
  // The best plane tilts through both levels: RMS between 0 and half the step.
  EXPECT_GT(rms, 0.005f);
  EXPECT_LT(rms, 0.04f + 1e-4f);
}

TEST(FitPlane, RefusesNonPlanarAndTooFewPoints) {
  std::mt19937 rng(101);
  const auto blob = test::random_cloud(rng, 10, 0.5f);
  Eigen::Vector3f normal;
  float d = 0.f;
  EXPECT_FALSE(fit_plane(blob.data(), static_cast<int>(blob.size()), 0.05f, normal, d));
  EXPECT_FALSE(fit_plane(blob.data(), 2, 0.05f, normal, d));
}

// Points along a ground ring of a spinning LiDAR as the map keeps them (an arc 10 m from the
// sensor, 20 cm apart, 2 cm of noise along the ray): planes through the arc at any tilt about it
// fit them, and the fitted normal's tilt follows the noise. With min_spread_ratio they are
// refused, while as many points spread over a patch of the ground still fit, with the true normal.
TEST(FitPlane, RefusesPointsAlongALineWithAMinimumSpread) {
  std::mt19937 rng(102);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  const Eigen::Vector3f sensor(0.0f, 0.0f, 1.9f);
  std::vector<Eigen::Vector3f> ring, patch;
  for (int i = 0; i < 5; ++i) {
    const float az = 0.02f * static_cast<float>(i);  // 20 cm apart along the arc
    const Eigen::Vector3f ground(10.0f * std::cos(az), 10.0f * std::sin(az), 0.0f);
    const Eigen::Vector3f ray = (ground - sensor).normalized();
    ring.push_back(ground + noise(rng) * ray);
    patch.emplace_back(10.0f + 0.3f * static_cast<float>(i % 3), 0.3f * static_cast<float>(i / 3), 0.0f);
  }
  Eigen::Vector3f normal;
  float d = 0.f;
  EXPECT_TRUE(fit_plane(ring.data(), 5, 0.1f, normal, d));  // without the check: some plane
  EXPECT_FALSE(fit_plane(ring.data(), 5, 0.1f, normal, d, nullptr, 0.02f));
  ASSERT_TRUE(fit_plane(patch.data(), 5, 0.1f, normal, d, nullptr, 0.02f));
  EXPECT_NEAR(std::abs(normal.z()), 1.0f, 1e-4f);
}

TEST(AssociationConfig, RefusesASpreadRatioOutsideItsRange) {
  for (const char* bad : {"-0.1", "1.0", ".nan"}) {
    ConfigNode node(YAML::Load(std::string("min_spread_ratio: ") + bad), "association");
    AssociationConfig c;
    try {
      c.load(node);
      ADD_FAILURE() << "accepted min_spread_ratio " << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("min_spread_ratio"), std::string::npos) << e.what();
    }
  }
}

struct PlaneMapFixture {
  /// Map: the floor z = 0 on a 0.1 m grid over [0, 10]², in an iVox index.
  std::unique_ptr<SpatialIndex> map;
  Eigen::Isometry3d T_WL = Eigen::Isometry3d::Identity();
  PlaneMapFixture() {
    map = make_spatial_index(SpatialIndexConfig{});
    std::vector<Eigen::Vector3f> pts;
    for (int i = 0; i <= 100; ++i) {
      for (int j = 0; j <= 100; ++j) pts.emplace_back(0.1f * i, 0.1f * j, 0.0f);
    }
    map->insert(pts);
    T_WL.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
    T_WL.translation() = Eigen::Vector3d(5, 5, 1.5);
  }
  /// Scan points (LiDAR frame) whose world position is at height `offset` above the floor.
  std::vector<Eigen::Vector3f> points_at(float offset, int n, std::mt19937& rng) const {
    std::uniform_real_distribution<float> u(2.0f, 8.0f);
    std::vector<Eigen::Vector3f> out;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p_W(u(rng), u(rng), offset);
      out.push_back((T_WL.inverse() * p_W).cast<float>());
    }
    return out;
  }
};

// Residual = signed height above the floor (the sign follows the fitted normal) and equals
// nᵀ p_W + d; points 0.3 m off the floor fail the quality screen (q = 1 − 0.9|r|/√range < 0.9).
TEST(Associator, ResidualsAgainstKnownPlaneAndScreening) {
  PlaneMapFixture f;
  std::mt19937 rng(102);
  constexpr int kInliers = 200, kOutliers = 50;
  constexpr float kInlierOffset = 0.02f, kOutlierOffset = 0.3f;
  std::vector<Eigen::Vector3f> scan = f.points_at(kInlierOffset, kInliers, rng);
  const auto outliers = f.points_at(kOutlierOffset, kOutliers, rng);
  scan.insert(scan.end(), outliers.begin(), outliers.end());

  Associator screened(AssociationConfig{});
  ConstraintSet set;
  screened.associate(scan, f.T_WL, *f.map, set);
  EXPECT_EQ(set.constraints.size(), static_cast<std::size_t>(kInliers));
  EXPECT_EQ(set.rejected_screening, static_cast<std::size_t>(kOutliers));
  EXPECT_EQ(set.rejected_no_neighbors + set.rejected_not_planar, 0u);
  for (const Constraint& c : set.constraints) {
    const Eigen::Vector3f p_W = (f.T_WL.cast<float>() * c.point);
    EXPECT_NEAR(std::abs(c.normal.z()), 1.0f, 1e-4f);
    EXPECT_NEAR(std::abs(c.residual), kInlierOffset, 1e-4f);
    EXPECT_NEAR(c.residual, c.normal.dot(p_W) + c.d, 1e-5f);
    EXPECT_GE(c.quality, 0.9f);
  }

  AssociationConfig off;
  off.screening = false;
  Associator unscreened(off);
  unscreened.associate(scan, f.T_WL, *f.map, set);
  EXPECT_EQ(set.constraints.size(), static_cast<std::size_t>(kInliers + kOutliers));
  EXPECT_EQ(set.rejected_screening, 0u);
}

// A map of ground rings 3 m apart (points 0.15 m apart along each): a scan point on a ring finds
// its neighbours along that ring only. Without the spread check each becomes a plane; with it
// every one is refused as not planar. The floor grid keeps every plane with the check on.
TEST(Associator, MinSpreadRatioRefusesRingNeighbourhoodsOnly) {
  auto rings = make_spatial_index(SpatialIndexConfig{});
  std::vector<Eigen::Vector3f> map_pts, scan;
  for (int r = 1; r <= 4; ++r) {
    const float radius = 3.0f * static_cast<float>(r);
    const int n = static_cast<int>(2.0f * static_cast<float>(M_PI) * radius / 0.15f);
    for (int i = 0; i < n; ++i) {
      const float az = 2.0f * static_cast<float>(M_PI) * static_cast<float>(i) / static_cast<float>(n);
      map_pts.emplace_back(radius * std::cos(az), radius * std::sin(az), 0.0f);
      const float between = az + static_cast<float>(M_PI) / static_cast<float>(n);  // half-way to the next
      if (i % 10 == 5) scan.emplace_back(radius * std::cos(between), radius * std::sin(between), 0.0f);
    }
  }
  rings->insert(map_pts);
  AssociationConfig off, on;
  on.min_spread_ratio = 0.05;
  ConstraintSet set;
  Associator(off).associate(scan, Eigen::Isometry3d::Identity(), *rings, set);
  EXPECT_EQ(set.constraints.size() + set.rejected_screening, scan.size());
  EXPECT_EQ(set.rejected_not_planar, 0u);
  Associator(on).associate(scan, Eigen::Isometry3d::Identity(), *rings, set);
  EXPECT_EQ(set.constraints.size(), 0u);
  EXPECT_EQ(set.rejected_not_planar, scan.size());

  PlaneMapFixture f;
  std::mt19937 rng(104);
  Associator(on).associate(f.points_at(0.0f, 100, rng), f.T_WL, *f.map, set);
  EXPECT_EQ(set.constraints.size(), 100u);
}

// Points far from the map find no neighbours; rescreen() re-evaluates residuals at a new pose.
TEST(Associator, NoNeighboursAndRescreen) {
  PlaneMapFixture f;
  std::mt19937 rng(103);
  Associator assoc(AssociationConfig{});
  ConstraintSet set;
  assoc.associate({Eigen::Vector3f(100, 100, 100)}, f.T_WL, *f.map, set);
  EXPECT_EQ(set.rejected_no_neighbors, 1u);

  assoc.associate(f.points_at(0.0f, 50, rng), f.T_WL, *f.map, set);
  ASSERT_EQ(set.constraints.size(), 50u);
  Eigen::Isometry3d lifted = f.T_WL;
  lifted.translation().z() += 0.1;  // every residual becomes ±0.1 m: still kept
  assoc.rescreen(lifted, set);
  ASSERT_EQ(set.constraints.size(), 50u);
  for (const Constraint& c : set.constraints) EXPECT_NEAR(std::abs(c.residual), 0.1f, 1e-4f);
  lifted.translation().z() += 0.9;  // 1 m: beyond max_residual, all dropped
  assoc.rescreen(lifted, set);
  EXPECT_EQ(set.constraints.size(), 0u);
  EXPECT_EQ(set.rejected_screening, 50u);
}

}  // namespace
}  // namespace fuse
