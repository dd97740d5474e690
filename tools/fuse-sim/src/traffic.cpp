#include "fuse/sim/traffic.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

namespace fuse::sim {

namespace {

// Whether the ray meets the box [lo, hi] within [0, t_max] (slab test; NaN from 0 * inf is
// ignored by the max / min order, as in the BVH).
bool ray_meets(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
               const Eigen::Vector3d& inv, double t_max) {
  double t0 = 0.0, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    const double n = (lo[a] - o[a]) * inv[a], f = (hi[a] - o[a]) * inv[a];
    t0 = std::max(t0, std::min(n, f));
    t1 = std::min(t1, std::max(n, f));
  }
  return t0 <= t1;
}

// Distance from p to the box [lo, hi].
double distance_to(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& p) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).norm();
}

Box merged(const Box& a, const Box& b) {
  Box m = a;
  m.min = a.min.cwiseMin(b.min);
  m.max = a.max.cwiseMax(b.max);
  return m;
}

}  // namespace

const char* mover_kind_name(MoverKind kind) { return kind == MoverKind::kCar ? "car" : "pedestrian"; }

Traffic::Traffic(std::vector<Mover> movers, double t0) : movers_(std::move(movers)), t0_(t0) {
  for (const Mover& m : movers_) {
    const std::string who = "traffic: mover " + std::to_string(m.id);
    if (!(m.length > 0.0) || !(m.width > 0.0) || !(m.height > 0.0) || !(m.speed > 0.0) || !std::isfinite(m.offset) ||
        !std::isfinite(m.speed))
      throw std::invalid_argument(who + ": size and speed must be positive, the offset finite");
    if (m.loop.size() < 2) throw std::invalid_argument(who + ": a loop needs at least two vertices");
    Loop loop;
    for (std::size_t k = 0; k < m.loop.size(); ++k) {
      const Eigen::Vector2d d = m.loop[(k + 1) % m.loop.size()] - m.loop[k];
      if (!d.allFinite() || (d.x() != 0.0) == (d.y() != 0.0))
        throw std::invalid_argument(who + ": segment " + std::to_string(k) + " is not along x or y, or is empty");
      loop.start.push_back(loop.total);
      loop.total += d.norm();
    }
    loops_.push_back(loop);
  }
}

double Traffic::arc(std::size_t i, double t) const {
  const Mover& m = movers_[i];
  const double total = loops_[i].total;
  double s = std::fmod(m.offset + m.speed * (t - t0_), total);
  if (s < 0.0) s += total;
  return s < total ? s : 0.0;
}

std::size_t Traffic::segment(std::size_t i, double s, Eigen::Vector2d& point) const {
  const Loop& loop = loops_[i];
  const std::vector<Eigen::Vector2d>& v = movers_[i].loop;
  const auto it = std::upper_bound(loop.start.begin(), loop.start.end(), s);
  const std::size_t k = it == loop.start.begin() ? 0 : static_cast<std::size_t>(it - loop.start.begin()) - 1;
  const Eigen::Vector2d a = v[k], b = v[(k + 1) % v.size()];
  const double length = (b - a).norm();
  point = a + std::clamp(s - loop.start[k], 0.0, length) / length * (b - a);
  return k;
}

Box Traffic::box_on(std::size_t i, std::size_t seg, const Eigen::Vector2d& centre) const {
  const Mover& m = movers_[i];
  const Eigen::Vector2d d = m.loop[(seg + 1) % m.loop.size()] - m.loop[seg];
  const bool along_x = d.x() != 0.0;
  const double hx = 0.5 * (along_x ? m.length : m.width), hy = 0.5 * (along_x ? m.width : m.length);
  Box b;
  b.min = {centre.x() - hx, centre.y() - hy, 0.0};
  b.max = {centre.x() + hx, centre.y() + hy, m.height};
  b.material = m.material;
  return b;
}

Box Traffic::box(std::size_t i, double t) const {
  Eigen::Vector2d c;
  const std::size_t k = segment(i, arc(i, t), c);
  return box_on(i, k, c);
}

void Traffic::pose(std::size_t i, double t, Eigen::Vector2d& centre, Eigen::Vector2d& direction) const {
  const std::size_t k = segment(i, arc(i, t), centre);
  const Mover& m = movers_[i];
  direction = (m.loop[(k + 1) % m.loop.size()] - m.loop[k]).normalized();
}

void Traffic::candidates(double t_a, double t_b, const Eigen::Vector3d& centre, double radius,
                         std::vector<MoverCandidate>& out) const {
  out.clear();
  for (std::size_t i = 0; i < movers_.size(); ++i) {
    const Mover& m = movers_[i];
    Eigen::Vector2d ca, cb;
    const double sa = arc(i, t_a), travel = m.speed * (t_b - t_a);
    const std::size_t ka = segment(i, sa, ca), kb = segment(i, arc(i, t_b), cb);
    const double segment_end = ka + 1 < loops_[i].start.size() ? loops_[i].start[ka + 1] : loops_[i].total;
    Box bound;
    if (ka == kb && sa + travel < segment_end) {  // straight on: the box slides from ca to cb
      bound = merged(box_on(i, ka, ca), box_on(i, kb, cb));
    } else {  // turns a corner within the interval: its centre stays within `travel` of ca
      const double r = 0.5 * std::max(m.length, m.width) + travel;
      bound.min = {ca.x() - r, ca.y() - r, 0.0};
      bound.max = {ca.x() + r, ca.y() + r, m.height};
    }
    if (distance_to(bound.min, bound.max, centre) > radius) continue;
    out.push_back({static_cast<std::uint32_t>(i), bound.min, bound.max});
  }
}

Hit Traffic::cast(const std::vector<MoverCandidate>& candidates, const Eigen::Vector3d& origin,
                  const Eigen::Vector3d& dir, double max_range, double t, std::uint32_t* mover) const {
  Hit best;
  const Eigen::Vector3d inv = dir.cwiseInverse();
  for (const MoverCandidate& c : candidates) {
    if (!ray_meets(c.lo, c.hi, origin, inv, std::min(max_range, best.range))) continue;
    const Hit h = intersect(box(c.index, t), origin, dir);
    if (h.range < best.range && h.range <= max_range) {
      best = h;
      if (mover) *mover = c.index;
    }
  }
  return best;
}

std::vector<Box> Traffic::swept_volume(double t_a, double t_b) const {
  std::vector<Box> out;
  for (std::size_t i = 0; i < movers_.size(); ++i) {
    const Mover& m = movers_[i];
    const Loop& loop = loops_[i];
    const std::size_t n = m.loop.size();
    double remaining = std::min(m.speed * (t_b - t_a), loop.total);  // beyond one lap: the whole loop
    double s = arc(i, t_a);
    Eigen::Vector2d p;
    std::size_t k = segment(i, s, p);
    // Segment by segment from where the box is at t_a, as far as it travels by t_b.
    for (std::size_t visited = 0; visited <= n; ++visited) {
      const double end = loop.start[k] + (m.loop[(k + 1) % n] - m.loop[k]).norm();
      const double take = std::clamp(end - s, 0.0, remaining);
      Eigen::Vector2d q;
      const Eigen::Vector2d a = m.loop[k], d = (m.loop[(k + 1) % n] - a).normalized();
      q = a + (s + take - loop.start[k]) * d;
      out.push_back(merged(box_on(i, k, p), box_on(i, k, q)));
      remaining -= take;
      if (remaining <= 0.0) break;
      k = (k + 1) % n;
      s = loop.start[k];
      p = m.loop[k];
    }
  }
  return out;
}

void Traffic::write_csv(const std::string& file) const {
  std::ofstream out(file);
  out << "id,kind,length_m,width_m,height_m,speed_mps,t0_s,offset_m,loop_length_m,loop\n";
  char buffer[256];
  for (std::size_t i = 0; i < movers_.size(); ++i) {
    const Mover& m = movers_[i];
    std::snprintf(buffer, sizeof buffer, "%u,%s,%.4f,%.4f,%.4f,%.6f,%.6f,%.6f,%.6f,", m.id, mover_kind_name(m.kind),
                  m.length, m.width, m.height, m.speed, t0_, m.offset, loops_[i].total);
    out << buffer;
    for (std::size_t k = 0; k < m.loop.size(); ++k) {
      std::snprintf(buffer, sizeof buffer, "%s%.6f %.6f", k == 0 ? "" : ";", m.loop[k].x(), m.loop[k].y());
      out << buffer;
    }
    out << "\n";
  }
  if (!out) throw std::runtime_error(file + ": cannot write");
}

}  // namespace fuse::sim
