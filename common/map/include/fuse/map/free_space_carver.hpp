// Free-space carving for the mapping policy (map_policy.hpp, `carve_s`): a point the map took in
// less than `carve_s` ago is on probation; when a ray of a later scan passes through it and
// goes on well beyond, the space is empty now and the point is taken out of the map. That is
// what a car or a pedestrian leaves behind when it moves on; a wall or a pole stays, because
// the rays towards it end on it.
//
// The test, for a young point c and a ray from o along the unit direction u with length L:
//     s = (c − o)·u > 0,   |c − o|² − s² < carve_radius²,   L ≥ s·(1 + carve_beyond) + carve_margin.
// The last condition keeps a ray from carving the surface it ends on just short of its end. A
// ray that grazes a surface (a corridor's wall, the ground far ahead) runs close to that
// surface's points long before its end, so a point is also kept when the map around it is a
// plane the ray meets at less than min_incidence_deg: a surface seen edge-on, not free space.
//
// Where the map around c is a plane (normal n), a test of the surface replaces the margin: the
// ray must cross c's plane within radius of c, at s_x = (c − o)·n / u·n, and end behind it by at
// least plane_gap, (L − s_x)·|u·n| ≥ plane_gap. The ray went through that surface where c is. A
// ray that ends on c's own surface, or on another just in front of it (the floor at the foot of a
// wall), does not carve c; the side of a car a metre in front of a wall is carved, where the
// margin alone needed the wall 0.15 × range + 0.5 m behind it.
//
// Finding the rays near c: the scan's rays are binned by direction in a range image (2° pixels)
// seen from a point of the path the LiDAR moved along during the scan, and c is tested against
// the rays of the pixels around its own direction. The path matters at vehicle speed (1.5 m per
// scan at 15 m/s): the rays are split into slices along it, each with its own image seen from
// its middle, so the window stays narrow. A ray missed by the window only means a point is not
// carved by that scan: every carve is decided by the exact test above.
//
// A point that later scans keep hitting is a surface that stays: once its cell (an edge of
// 2·radius) has been hit over release_s, it leaves probation untested. A moving object does
// not stay in a cell that long (a pedestrian at 1.4 m/s crosses 0.3 m in 0.2 s). This keeps the
// points on probation few (what is new, what moved, what is seen too rarely to tell), and a
// settled wall safe from an unlucky ray.
//
// Work per scan is bounded (`max_tests` young points at most, in turn): a fast drive through
// new space cannot make a scan slow.
//
// Looking back (`lookback_s`, seen_empty()): the same test, the other way in time. The rays of
// the trusted scans of the last lookback_s are kept; a point of a new scan that one of them
// passed through lies in space seen empty then, so what is there now came in: a car crossing,
// an oncoming car, a pedestrian stepping out. The estimator leaves it out of the update and the
// map. Only a point with no map point within radius is judged: beside a map point (a wall seen
// again, a door frame) a ray passing close by proves nothing. What carving cannot see through
// again (a mover that leaves the field of view, or stays in front of the ray) this can, when the
// place was in view before the mover came; a car driving ahead in the same lane hides its own
// place from both. Bounded too: lookback_tests point tests a scan, against scans spread over
// lookback_s.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <unordered_map>
#include <vector>

#include "fuse/association/spatial_index.hpp"

namespace fuse {

struct CarveConfig {
  double probation_s = 0.0;  ///< s, how long an inserted point can be carved (0: off)
  double radius = 0.25;      ///< m, how close a ray must pass to a point to carve it
  double beyond = 0.15;      ///< the ray must go on by this fraction of the point's range ...
  double margin = 0.5;       ///< m, ... plus this
  double min_incidence_deg = 15.0;  ///< a ray shallower than this to the point's plane does not carve it
  double release_s = 0.5;    ///< s, a point whose cell is hit over this long leaves probation
  std::size_t max_tests = 20000;  ///< young points tested per scan at most
  double plane_gap = 0.3;  ///< m, how far behind a point's plane a ray must end to carve it
  /// s: the rays of the trusted scans of this long before are kept; a new point one of them
  /// passed through (the same test) lies where the space was empty then: a mover (seen_empty).
  /// 0: off.
  double lookback_s = 0.0;
  /// Point tests per scan at most when looking back: a scan of n points is tested against
  /// lookback_tests / n of the scans kept (at least one), spread over lookback_s.
  std::size_t lookback_tests = 20000;
};

class FreeSpaceCarver {
 public:
  explicit FreeSpaceCarver(const CarveConfig& config) : config_(config) {}

  /// Puts the points the map has just taken in (at time t) on probation.
  void add(double t, const std::vector<Eigen::Vector3f>& inserted);
  /// Tests the young points against one scan's rays, ray i from origins[i] to ends[i] (world
  /// frame, measured at t), and returns the carved ones (no longer on probation; the caller
  /// removes them from the map). Points older than probation_s at t leave probation first.
  const std::vector<Eigen::Vector3f>& carve(double t, const std::vector<Eigen::Vector3f>& ends,
                                            const std::vector<Eigen::Vector3f>& origins, const SpatialIndex& map);
  /// Marks (empty[i] = 1) the points, measured at t, that a ray of a scan within lookback_s before
  /// t passed through: that space was empty then, so what is there now moved in. Returns how
  /// many. Uses only the scans given to carve() (trusted ones).
  std::size_t seen_empty(double t, const std::vector<Eigen::Vector3f>& points, const SpatialIndex& map,
                         std::vector<std::uint8_t>& empty);
  std::size_t on_probation() const { return young_.size(); }
  std::size_t released() const { return released_; }

 private:
  struct Young {
    Eigen::Vector3f p;
    double t;
    std::uint32_t cell;  ///< index into cells_
  };
  /// When the scans hit a cell holding young points: first (its first point's insertion) and last.
  struct Hits {
    std::uint64_t key;
    double first, last;
  };
  struct Ray {
    Eigen::Vector3f o, u;
    float s_max;  ///< carves only points projecting onto (0, s_max)
    float length;
  };
  /// One scan's rays, binned: slice k's rays of pixel q are rays[start[k·P + q] .. start[k·P + q + 1]).
  struct RayImage {
    double t = 0.0;
    int slices = 1;
    Eigen::Vector3f slice_origin[8];  ///< the point each slice's image is seen from
    float slice_half = 0.0f;          ///< how far a slice's ray origins lie from it, at most
    std::vector<std::uint32_t> start;
    std::vector<Ray> rays;
  };
  std::uint64_t cell_of(const Eigen::Vector3f& p) const;
  /// Ends the probation of points older than probation_s at t; frees cells no longer hit.
  void expire(double t);
  void note_hits(double t, const std::vector<Eigen::Vector3f>& ends);
  void bin_rays(const std::vector<Eigen::Vector3f>& ends, const std::vector<Eigen::Vector3f>& origins, RayImage& image);
  /// Whether a ray of `image` passes through c (the test at the top of this file). plane_state
  /// and normal cache the plane around c (0 not fitted yet, 1 a plane, 2 none) across calls.
  bool carves(const Eigen::Vector3f& c, const RayImage& image, const SpatialIndex& map, int& plane_state,
              Eigen::Vector3f& normal) const;
  /// Whether the ray along u meets the map's surface at c at min_incidence_deg or more (true
  /// where the map around c is not a plane: nothing to graze).
  bool steep_enough(const Eigen::Vector3f& c, const Eigen::Vector3f& u, const SpatialIndex& map, int& plane_state,
                    Eigen::Vector3f& normal) const;

  CarveConfig config_;
  std::deque<Young> young_;
  std::vector<Hits> cells_;                             ///< a pool: freed records are reused
  std::vector<std::uint32_t> free_cells_;
  std::unordered_map<std::uint64_t, std::uint32_t> cell_index_;  ///< key → cells_ index
  double swept_t_ = -1e300;
  std::size_t scans_ = 0, released_ = 0;
  RayImage image_;                 ///< this scan's rays
  std::deque<RayImage> history_;   ///< earlier trusted scans' rays within lookback_s, oldest first
  std::vector<RayImage> spare_;    ///< images no longer needed, their buffers reused
  std::vector<std::uint32_t> cursor_, bin_;
  std::vector<Ray> unsorted_;
  std::vector<Eigen::Vector3f> carved_;
};

}  // namespace fuse
