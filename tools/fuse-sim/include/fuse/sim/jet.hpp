// A scalar function of time carried with its first two time derivatives (second-order forward
// automatic differentiation). The trajectory is built from Jets so that velocity, acceleration
// and angular velocity are exact derivatives of the pose, never finite differences.
#pragma once

#include <cmath>

namespace fuse::sim {

struct Jet {
  double v = 0.0;   ///< value f(t)
  double d = 0.0;   ///< df/dt
  double dd = 0.0;  ///< d2f/dt2

  static Jet constant(double c) { return {c, 0.0, 0.0}; }
};

inline Jet operator+(const Jet& a, const Jet& b) { return {a.v + b.v, a.d + b.d, a.dd + b.dd}; }
inline Jet operator-(const Jet& a, const Jet& b) { return {a.v - b.v, a.d - b.d, a.dd - b.dd}; }
inline Jet operator*(double s, const Jet& a) { return {s * a.v, s * a.d, s * a.dd}; }
/// Leibniz rule: (fg)' = f'g + fg', (fg)'' = f''g + 2f'g' + fg''.
inline Jet operator*(const Jet& a, const Jet& b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d, a.dd * b.v + 2.0 * a.d * b.d + a.v * b.dd};
}
/// Chain rule for sin(f): (sin f)' = cos f f', (sin f)'' = -sin f f'^2 + cos f f''.
inline Jet sin(const Jet& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return {s, c * a.d, -s * a.d * a.d + c * a.dd};
}
/// Chain rule for cos(f): (cos f)' = -sin f f', (cos f)'' = -cos f f'^2 - sin f f''.
inline Jet cos(const Jet& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return {c, -s * a.d, -c * a.d * a.d - s * a.dd};
}
/// f(u(t)) from f, f_u, f_uu at u(t): (f o u)' = f_u u', (f o u)'' = f_uu u'^2 + f_u u''.
inline Jet compose(double f, double f_u, double f_uu, const Jet& u) {
  return {f, f_u * u.d, f_uu * u.d * u.d + f_u * u.dd};
}

}  // namespace fuse::sim
