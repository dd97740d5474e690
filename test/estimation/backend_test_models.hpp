// Small measurement models shared by the update-backend tests (update_backends_test.cpp,
// nano_test.cpp): fixed point-to-plane correspondences, a linear-Gaussian observation of the
// additive state blocks, and a 2-D range-bearing observation of the position.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "fuse/estimation/point_to_plane_model.hpp"
#include "test_helpers.hpp"

namespace fuse::test {

/// Point-to-plane constraints with fixed correspondences (no association).
class FixedPlanes final : public MeasurementModel {
 public:
  FixedPlanes(std::vector<Constraint> constraints, double sigma) : constraints_(std::move(constraints)), sigma_(sigma) {}
  bool linearize(const NavState& x, int, LinearSystem& out) override {
    out = LinearSystem{};
    const double w = 1.0 / (sigma_ * sigma_);
    double lever2 = 0.0;
    for (const Constraint& c : constraints_) {
      const Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
      const double r = point_to_plane_residual(x, c);
      out.information += w * H.transpose() * H;
      out.gradient += w * r * H.transpose();
      out.cost += w * r * r;
      lever2 += (x.R_IL * c.point.cast<double>() + x.p_IL).squaredNorm();
    }
    out.count = constraints_.size();
    if (out.count > 0) out.characteristic_length = std::sqrt(lever2 / static_cast<double>(out.count));
    return out.count > 0;
  }

  /// Points on planes n·x + d = 0 around the true sensor position, in the true LiDAR frame.
  static std::vector<Constraint> observe(const std::vector<Eigen::Vector4d>& planes, const NavState& truth,
                                         std::mt19937& rng, int per_plane = 60) {
    const Eigen::Isometry3d T_LW = (truth.T_WI() * truth.T_IL()).inverse();
    std::vector<Constraint> out;
    for (const Eigen::Vector4d& pl : planes) {
      const Eigen::Vector3d n = pl.head<3>().normalized();
      for (int i = 0; i < per_plane; ++i) {
        Eigen::Vector3d p = truth.p + random_vector(rng, 4.0);
        p -= (n.dot(p) + pl(3)) * n;
        Constraint c;
        c.point = (T_LW * p).cast<float>();
        c.normal = n.cast<float>();
        c.d = static_cast<float>(pl(3));
        out.push_back(c);
      }
    }
    return out;
  }

 private:
  std::vector<Constraint> constraints_;
  double sigma_;
};

/// z = A [p; p_IL] + v, v ~ N(0, W⁻¹): residual r = A [p; p_IL] − z (linear in the additive blocks).
class LinearObservation final : public MeasurementModel {
 public:
  LinearObservation(Eigen::MatrixXd A, Eigen::VectorXd z, Eigen::MatrixXd W) : A_(std::move(A)), z_(std::move(z)), W_(std::move(W)) {}
  /// The Jacobian over the full error state (columns of p and p_IL).
  Eigen::MatrixXd H() const {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(A_.rows(), kStateDim);
    H.middleCols<3>(Idx::kPos) = A_.leftCols<3>();
    H.middleCols<3>(Idx::kExtPos) = A_.rightCols<3>();
    return H;
  }
  Eigen::VectorXd residual(const NavState& x) const {
    Eigen::Matrix<double, 6, 1> s;
    s << x.p, x.p_IL;
    return A_ * s - z_;
  }
  bool linearize(const NavState& x, int, LinearSystem& out) override {
    out = LinearSystem{};
    const Eigen::MatrixXd Hobs = H().leftCols<kObsDim>();
    const Eigen::VectorXd r = residual(x);
    out.information = Hobs.transpose() * W_ * Hobs;
    out.gradient = Hobs.transpose() * W_ * r;
    out.cost = r.dot(W_ * r);
    out.count = static_cast<std::size_t>(r.size());
    return true;
  }

 private:
  Eigen::MatrixXd A_;
  Eigen::VectorXd z_;
  Eigen::MatrixXd W_;
};

/// Range and bearing of the sensor position (x, y) seen from a landmark at the origin.
class RangeBearing final : public MeasurementModel {
 public:
  RangeBearing(double range, double bearing, double sigma_range, double sigma_bearing)
      : range_(range), bearing_(bearing), w_range_(1.0 / (sigma_range * sigma_range)), w_bearing_(1.0 / (sigma_bearing * sigma_bearing)) {}
  /// ℓ(p) = ½ Σ w r² at a position.
  double nll(double px, double py) const {
    const double rr = std::hypot(px, py) - range_;
    const double rb = wrap(std::atan2(py, px) - bearing_);
    return 0.5 * (w_range_ * rr * rr + w_bearing_ * rb * rb);
  }
  bool linearize(const NavState& x, int, LinearSystem& out) override {
    out = LinearSystem{};
    const double px = x.p.x(), py = x.p.y();
    const double rho2 = std::max(px * px + py * py, 1e-12), rho = std::sqrt(rho2);
    Eigen::Matrix<double, 1, kObsDim> Hr = Eigen::Matrix<double, 1, kObsDim>::Zero(), Hb = Hr;
    Hr(0) = px / rho;
    Hr(1) = py / rho;
    Hb(0) = -py / rho2;
    Hb(1) = px / rho2;
    const double rr = rho - range_, rb = wrap(std::atan2(py, px) - bearing_);
    out.information = w_range_ * Hr.transpose() * Hr + w_bearing_ * Hb.transpose() * Hb;
    out.gradient = w_range_ * rr * Hr.transpose() + w_bearing_ * rb * Hb.transpose();
    out.cost = w_range_ * rr * rr + w_bearing_ * rb * rb;
    out.count = 2;
    return true;
  }

 private:
  static double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }
  double range_, bearing_, w_range_, w_bearing_;
};

}  // namespace fuse::test
