// Moving objects ("movers": other cars, pedestrians): boxes that go round closed loops of
// axis-aligned segments at a constant speed. A mover's pose is a function of time: at time t it
// stands at arc length s(t) = offset + speed (t - t0), modulo the loop's length, along its loop,
// its box axis-aligned with the length along the current segment (the box turns at the loop's
// corners), standing on the ground z = 0. The LiDAR casts every shot against the movers at the
// shot's own time: a per-scan list of candidates (movers whose box, swept over the scan's 0.1 s,
// comes within range) keeps the cast fast; each candidate is tested first against its swept bound.
// Movers do not interact with each other (two of them may pass through one another).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "fuse/sim/world.hpp"

namespace fuse::sim {

enum class MoverKind : std::uint8_t { kCar, kPedestrian };
/// "car" or "pedestrian".
const char* mover_kind_name(MoverKind kind);

struct Mover {
  std::uint32_t id = 0;
  MoverKind kind = MoverKind::kCar;
  double length = 1.0, width = 1.0, height = 1.0;  ///< box: along travel, across, up (metres)
  double speed = 1.0;                              ///< m/s along the loop (> 0)
  double offset = 0.0;                             ///< arc length along the loop at t0 (m)
  /// The loop's vertices in travel order (the last joins the first); every segment along x or y.
  std::vector<Eigen::Vector2d> loop;
  Material material;
};

/// A mover's swept bound over a short interval, for one scan's casts.
struct MoverCandidate {
  std::uint32_t index = 0;  ///< into Traffic::movers()
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
};

class Traffic {
 public:
  Traffic() = default;
  /// Throws std::invalid_argument on a loop with fewer than two vertices, a segment neither along
  /// x nor along y or of zero length, or a non-positive size or speed.
  Traffic(std::vector<Mover> movers, double t0);

  const std::vector<Mover>& movers() const { return movers_; }
  double t0() const { return t0_; }
  double loop_length(std::size_t i) const { return loops_[i].total; }

  /// Mover i's box at time t.
  Box box(std::size_t i, double t) const;
  /// Mover i's ground position (box centre, x y) and unit travel direction at time t.
  void pose(std::size_t i, double t, Eigen::Vector2d& centre, Eigen::Vector2d& direction) const;

  /// The movers whose boxes during [t_a, t_b] may come within `radius` of `centre`, each with a
  /// bound of its box over the interval (conservative: it covers a turn at a corner).
  void candidates(double t_a, double t_b, const Eigen::Vector3d& centre, double radius,
                  std::vector<MoverCandidate>& out) const;
  /// The closest hit of the ray origin + r dir (r in [0, max_range]) on the candidates' boxes at
  /// time t (t within the candidates' interval); invalid if none. `mover` gets the hit's index.
  Hit cast(const std::vector<MoverCandidate>& candidates, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
           double max_range, double t, std::uint32_t* mover = nullptr) const;

  /// The exact volume swept by every box over [t_a, t_b]: one box per loop segment (or part of
  /// one) travelled, the box slid along the segment from where it entered to where it left.
  std::vector<Box> swept_volume(double t_a, double t_b) const;

  /// moving_objects.csv (format in tools/fuse-sim/README.md); throws std::runtime_error.
  void write_csv(const std::string& file) const;

 private:
  struct Loop {
    std::vector<double> start;  ///< arc length at each vertex (start[0] = 0)
    double total = 0.0;
  };
  /// Arc length along mover i's loop at time t, in [0, total).
  double arc(std::size_t i, double t) const;
  /// The segment holding arc length s, and the point there.
  std::size_t segment(std::size_t i, double s, Eigen::Vector2d& point) const;
  Box box_on(std::size_t i, std::size_t seg, const Eigen::Vector2d& centre) const;

  std::vector<Mover> movers_;
  std::vector<Loop> loops_;
  double t0_ = 0.0;
};

}  // namespace fuse::sim
