// A smooth 3-D path c(u), C3 in its parameter u: a chain of degree-7 Hermite pieces whose knots
// fix the position and the first three derivatives. Built from a polyline with rounded corners:
// straight segments are exact lines (|c'| = 1, u = arc length); every corner is bent through a
// knot on its arc (curvature 1/R) with zero curvature at the entry and exit, so the curvature
// rises and falls smoothly (clothoid-like) and c is C3 everywhere.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace fuse::sim {

/// Position and derivatives with respect to u at one knot.
struct PathKnot {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d d1 = Eigen::Vector3d::UnitX();
  Eigen::Vector3d d2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d d3 = Eigen::Vector3d::Zero();
};

/// c(u) and its first three u-derivatives.
struct PathPoint {
  Eigen::Vector3d c, c1, c2, c3;
};

/// Horizontal heading theta(u) = atan2(c1.y, c1.x) with d(theta)/du and d2(theta)/du2.
struct Heading {
  double theta = 0.0, theta_u = 0.0, theta_uu = 0.0;
};

class Path {
 public:
  /// Knots and the u-length of each piece (lengths.size() == knots.size() - 1, all > 0).
  Path(const std::vector<PathKnot>& knots, const std::vector<double>& lengths);

  double u_end() const { return u_start_.empty() ? 0.0 : u_start_.back() + lengths_.back() - offset_; }
  PathPoint at(double u) const;  ///< u is clamped to [0, u_end]
  /// The same curve from parameter u0 on (u0 in [0, u_end)): c'(u) = c(u0 + u). A walk that
  /// starts part of the way along the scenario's path (fuse-sim --start-at).
  Path from(double u0) const;
  static Heading heading(const PathPoint& point);
  /// Geometric length of the curve (Gauss-Legendre quadrature of |c'| on each piece).
  double arc_length() const;
  std::size_t num_pieces() const { return lengths_.size(); }

 private:
  using Coeffs = Eigen::Matrix<double, 3, 8>;  // c(s) = sum_i coeffs.col(i) s^i, s = u / length
  std::vector<Coeffs> coeffs_;
  std::vector<double> lengths_, u_start_;
  double offset_ = 0.0;  ///< parameter of the original path where this one starts (from)
};

/// One polyline vertex: a corner rounded with radius `radius` (ignored at the two ends).
struct Waypoint {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double radius = 1.0;
};

/// Where a rounded corner lies on the path: its arc spans [u_entry, u_exit] (waypoint `waypoint`).
struct CornerSpan {
  double u_entry = 0.0, u_exit = 0.0;
  std::size_t waypoint = 0;
};

/// Builds a Path through waypoints with rounded corners (see the file comment). The first and last
/// waypoints are the ends (the path starts and stops there, on a straight segment). Throws
/// std::invalid_argument when segments are too short for their corners or a radius is not positive.
/// `corners`, if given, receives the span of every corner in path order (e.g. to slow down there).
Path make_rounded_polyline(const std::vector<Waypoint>& waypoints, std::vector<CornerSpan>* corners = nullptr);

}  // namespace fuse::sim
