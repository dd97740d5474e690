#include "fuse/sim/path.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fuse::sim {

namespace {

// Coefficients a4..a7 of the degree-7 Hermite polynomial on s in [0, 1] from the end conditions
// sum_i binom-like rows: c(1), c'(1), c''(1), c'''(1) (rows: d^k/ds^k s^i at s = 1, i = 4..7).
const Eigen::Matrix4d& end_condition_inverse() {
  static const Eigen::Matrix4d inv = [] {
    Eigen::Matrix4d m;
    m << 1, 1, 1, 1,       //
        4, 5, 6, 7,        //
        12, 20, 30, 42,    //
        24, 60, 120, 210;  //
    return Eigen::Matrix4d(m.inverse());
  }();
  return inv;
}

// Falling factorial i (i-1) ... (i-k+1): the k-th derivative factor of s^i.
double falling(int i, int k) {
  double f = 1.0;
  for (int j = 0; j < k; ++j) f *= (i - j);
  return f;
}

// 8-point Gauss-Legendre nodes and weights on [-1, 1] (exact for degree 15 polynomials).
constexpr double kGlNodes[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                0.9602898564975363};
constexpr double kGlWeights[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                  0.1012285362903763};
// Sub-intervals per piece for the arc length quadrature (|c'| is not polynomial).
constexpr int kArcLengthSubdivisions = 16;

}  // namespace

Path::Path(const std::vector<PathKnot>& knots, const std::vector<double>& lengths) {
  if (knots.size() < 2 || lengths.size() + 1 != knots.size())
    throw std::invalid_argument("Path: need at least 2 knots and one length per piece");
  double u = 0.0;
  for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
    const double L = lengths[k];
    if (!(L > 0.0) || !std::isfinite(L))
      throw std::invalid_argument("Path: piece " + std::to_string(k) + " has a non-positive length");
    const PathKnot& a = knots[k];
    const PathKnot& b = knots[k + 1];
    Coeffs c = Coeffs::Zero();
    // Start conditions in s = u / L: d^k c / ds^k = L^k d^k c / du^k, a_k = (d^k c/ds^k)(0) / k!.
    c.col(0) = a.p;
    c.col(1) = L * a.d1;
    c.col(2) = L * L * a.d2 / 2.0;
    c.col(3) = L * L * L * a.d3 / 6.0;
    const Eigen::Vector3d end[4] = {b.p, L * b.d1, L * L * b.d2, L * L * L * b.d3};
    Eigen::Matrix<double, 3, 4> rhs;
    for (int r = 0; r < 4; ++r) {
      Eigen::Vector3d known = Eigen::Vector3d::Zero();
      for (int i = r; i < 4; ++i) known += falling(i, r) * c.col(i);
      rhs.col(r) = end[r] - known;
    }
    c.rightCols<4>() = rhs * end_condition_inverse().transpose();
    coeffs_.push_back(c);
    lengths_.push_back(L);
    u_start_.push_back(u);
    u += L;
  }
}

Path Path::from(double u0) const {
  if (!(u0 >= 0.0) || !(u0 < u_end())) throw std::invalid_argument("Path::from: the start must lie on the path");
  Path p = *this;
  p.offset_ += u0;
  return p;
}

PathPoint Path::at(double u) const {
  const double uc = std::clamp(u, 0.0, u_end()) + offset_;
  auto it = std::upper_bound(u_start_.begin(), u_start_.end(), uc);
  const std::size_t k = it == u_start_.begin() ? 0 : static_cast<std::size_t>(it - u_start_.begin()) - 1;
  const double L = lengths_[k];
  const double s = std::clamp((uc - u_start_[k]) / L, 0.0, 1.0);
  const Coeffs& a = coeffs_[k];
  // Horner evaluation of the polynomial and its first three derivatives in s.
  Eigen::Vector3d p = a.col(7), p1 = Eigen::Vector3d::Zero(), p2 = p1, p3 = p1;
  for (int i = 6; i >= 0; --i) {
    p3 = p3 * s + p2;
    p2 = p2 * s + p1;
    p1 = p1 * s + p;
    p = p * s + a.col(i);
  }
  // p1, p2, p3 hold c', c''/2, c'''/6 in s; convert to u: d/du = (1/L) d/ds.
  return {p, p1 / L, 2.0 * p2 / (L * L), 6.0 * p3 / (L * L * L)};
}

Heading Path::heading(const PathPoint& q) {
  // theta = atan2(y', x'); theta_u = N / D with N = x'y'' - y'x'', D = x'^2 + y'^2;
  // theta_uu = (N' D - N D') / D^2, N' = x'y''' - y'x''', D' = 2 (x'x'' + y'y'').
  const double x1 = q.c1.x(), y1 = q.c1.y(), x2 = q.c2.x(), y2 = q.c2.y();
  const double x3 = q.c3.x(), y3 = q.c3.y();
  const double N = x1 * y2 - y1 * x2, D = x1 * x1 + y1 * y1;
  const double Nd = x1 * y3 - y1 * x3, Dd = 2.0 * (x1 * x2 + y1 * y2);
  return {std::atan2(y1, x1), N / D, (Nd * D - N * Dd) / (D * D)};
}

double Path::arc_length() const {
  double total = 0.0;
  for (std::size_t k = 0; k < lengths_.size(); ++k) {
    const double h = lengths_[k] / kArcLengthSubdivisions;
    for (int j = 0; j < kArcLengthSubdivisions; ++j) {
      const double mid = u_start_[k] + (j + 0.5) * h;
      for (int g = 0; g < 4; ++g)
        for (double sign : {-1.0, 1.0}) {
          const double u = mid + sign * 0.5 * h * kGlNodes[g];  // on the original path
          if (u >= offset_) total += 0.5 * h * kGlWeights[g] * at(u - offset_).c1.norm();
        }
    }
  }
  return total;
}

Path make_rounded_polyline(const std::vector<Waypoint>& w, std::vector<CornerSpan>* corners) {
  if (corners) corners->clear();
  if (w.size() < 2) throw std::invalid_argument("rounded polyline: need at least 2 waypoints");
  std::vector<PathKnot> knots;
  std::vector<double> lengths;
  // Knots: start, then per interior corner (entry, arc middle, exit), then end. Between corner
  // knots the pieces are straight lines or half arcs whose u-length is the circle's arc length.
  auto line_knot = [](const Eigen::Vector3d& p, const Eigen::Vector3d& dir) {
    PathKnot k;
    k.p = p;
    k.d1 = dir;
    return k;
  };
  const Eigen::Vector3d first_dir = (w[1].p - w[0].p).normalized();
  knots.push_back(line_knot(w[0].p, first_dir));
  for (std::size_t i = 1; i + 1 < w.size(); ++i) {
    const Eigen::Vector3d a = (w[i].p - w[i - 1].p).normalized();
    const Eigen::Vector3d b = (w[i + 1].p - w[i].p).normalized();
    const double cos_turn = std::clamp(a.dot(b), -1.0, 1.0);
    const double turn = std::acos(cos_turn);
    if (!(w[i].radius > 0.0)) throw std::invalid_argument("rounded polyline: radius must be positive");
    if (turn > 0.75 * M_PI)
      throw std::invalid_argument("rounded polyline: corner " + std::to_string(i) +
                                  " turns more than 135 deg; split it into two corners");
    if (turn < 1e-9) continue;  // collinear: no corner
    const double R = w[i].radius;
    const double T = R * std::tan(turn / 2.0);  // tangent length: vertex to arc ends
    const Eigen::Vector3d entry = w[i].p - T * a;
    const double straight = (entry - knots.back().p).dot(a);
    if (straight < 0.0)
      throw std::invalid_argument("rounded polyline: segment before waypoint " + std::to_string(i) +
                                  " is too short for its corner radii");
    if (straight > 0.0) {
      lengths.push_back(straight);
      knots.push_back(line_knot(entry, a));
    }
    // Arc middle: tangent along (a + b), centre of curvature along (b - a), circle derivatives
    // c'' = kappa n, c''' = -kappa^2 t with kappa = 1 / R.
    const Eigen::Vector3d t_mid = (a + b).normalized();
    const Eigen::Vector3d n_mid = (b - a).normalized();
    const double kappa = 1.0 / R;
    PathKnot mid;
    mid.p = w[i].p + (R / std::cos(turn / 2.0) - R) * n_mid;
    mid.d1 = t_mid;
    mid.d2 = kappa * n_mid;
    mid.d3 = -kappa * kappa * t_mid;
    const double half_arc = 0.5 * R * turn;
    if (corners) {
      double u_entry = 0.0;
      for (double l : lengths) u_entry += l;
      corners->push_back({u_entry, u_entry + 2.0 * half_arc, i});
    }
    lengths.push_back(half_arc);
    knots.push_back(mid);
    lengths.push_back(half_arc);
    knots.push_back(line_knot(w[i].p + T * b, b));
  }
  const Eigen::Vector3d last_dir = (w.back().p - w[w.size() - 2].p).normalized();
  const double last_straight = (w.back().p - knots.back().p).dot(last_dir);
  if (!(last_straight > 0.0))
    throw std::invalid_argument("rounded polyline: last segment is too short for its corner");
  lengths.push_back(last_straight);
  knots.push_back(line_knot(w.back().p, last_dir));
  return Path(knots, lengths);
}

}  // namespace fuse::sim
