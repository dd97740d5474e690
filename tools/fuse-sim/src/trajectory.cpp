#include "fuse/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace fuse::sim {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

// sum_i a_i sin(2 pi f_i tau + phi_i) as a Jet of tau.
Jet oscillation_sum(const std::vector<Oscillation>& terms, double tau) {
  Jet sum;
  for (const Oscillation& o : terms) {
    const double w = kTwoPi * o.frequency_hz;
    sum = sum + o.amplitude * sin(Jet{w * tau + o.phase, w, 0.0});
  }
  return sum;
}

// R = Rz(psi) Ry(theta) Rx(phi) and the body angular velocity from the Euler rates:
// w = [phi' - psi' sin(theta), theta' cos(phi) + psi' sin(phi) cos(theta),
//      -theta' sin(phi) + psi' cos(phi) cos(theta)].
void attitude_zyx(const Jet& yaw, const Jet& pitch, const Jet& roll, Eigen::Matrix3d& R, Eigen::Vector3d& w) {
  const double sy = std::sin(yaw.v), cy = std::cos(yaw.v);
  const double sp = std::sin(pitch.v), cp = std::cos(pitch.v);
  const double sr = std::sin(roll.v), cr = std::cos(roll.v);
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  w = {roll.d - yaw.d * sp, pitch.d * cr + yaw.d * sr * cp, -pitch.d * sr + yaw.d * cr * cp};
}

}  // namespace

Trajectory::Trajectory(Path path, const TimeLawConfig& time_law, const MotionConfig& motion, double t0)
    : path_(std::move(path)), time_law_(time_law, path_.u_end()), motion_(motion), t0_(t0) {
  if (!motion_.suspension.enabled) return;
  // The suspension responds to the acceleration of the path point c(u(t)) in the heading frame:
  // a = c' u'' + c'' u'^2, forward along the heading, lateral to its left.
  const double stopped = time_law_.duration() - time_law_.config().rest_end_s;
  suspension_.emplace(motion_.suspension, time_law_.duration(), stopped, [this](double tau) {
    const TimeLawSample s = time_law_.at(tau);
    const PathPoint c = path_.at(s.u);
    const Eigen::Vector3d a = c.c1 * s.u2 + c.c2 * (s.u1 * s.u1);
    const double theta = Path::heading(c).theta, ch = std::cos(theta), sh = std::sin(theta);
    return Eigen::Vector2d(ch * a.x() + sh * a.y(), -sh * a.x() + ch * a.y());
  });
}

TrajectoryState Trajectory::state(double t) const {
  const double tau = std::clamp(t - t0_, 0.0, time_law_.duration());
  const TimeLawSample s = time_law_.at(tau);
  const Jet u{s.u, s.u1, s.u2};
  const PathPoint c = path_.at(s.u);
  const Heading h = Path::heading(c);

  // Speed envelope e = u' / rate: 0 at rest, 1 when cruising (with its own derivatives).
  const double rate = time_law_.config().rate;
  const Jet envelope{s.u1 / rate, s.u2 / rate, s.u3 / rate};
  const Jet heading = compose(h.theta, h.theta_u, h.theta_uu, u);
  const Jet lateral = envelope * oscillation_sum(motion_.lateral, tau);
  const Jet vertical = envelope * oscillation_sum(motion_.vertical, tau);

  // p = c(u) + lateral * n(heading) + vertical * z, with the left normal n = (-sin, cos, 0).
  const Jet nx = -1.0 * sin(heading), ny = cos(heading);  // (sin and cos of one angle: cheap, kept simple)
  Jet p[3];
  for (int i = 0; i < 3; ++i) p[i] = compose(c.c[i], c.c1[i], c.c2[i], u);
  p[0] = p[0] + lateral * nx;
  p[1] = p[1] + lateral * ny;
  p[2] = p[2] + vertical;

  const Jet yaw = heading + envelope * oscillation_sum(motion_.yaw, tau);
  Jet pitch = Jet::constant(motion_.pitch_offset) + envelope * oscillation_sum(motion_.pitch, tau);
  Jet roll = Jet::constant(motion_.roll_offset) + envelope * oscillation_sum(motion_.roll, tau);
  if (suspension_) {
    Jet body_pitch, body_roll;
    suspension_->at(tau, body_pitch, body_roll);
    pitch = pitch + body_pitch;
    roll = roll + body_roll;
  }

  TrajectoryState out;
  out.t = t0_ + tau;
  out.p = {p[0].v, p[1].v, p[2].v};
  out.v = {p[0].d, p[1].d, p[2].d};
  out.a = {p[0].dd, p[1].dd, p[2].dd};
  attitude_zyx(yaw, pitch, roll, out.R, out.omega_body);
  return out;
}

}  // namespace fuse::sim
