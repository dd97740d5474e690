// Global localization in a saved map: the sensor's pose in the map from a gravity-aligned submap,
// with no initial guess (or within a window around a requested pose).
//
// Both frames have z up (the map's and the session's, from static initialisation), so four
// degrees of freedom remain: the sensor position t ∈ R³ and the heading ψ. The score of a pose is
// the mean over the submap points q_n (relative to the sensor) of a grid value at their cell,
//   S(t, ψ) = 1/(2N) Σ_n G₀(⌊(Rz(ψ) q_n + t − o)/r⌋),
// G₀ = 2 within one cell of a cell holding a map point, 1 within two, 0 elsewhere (Chebyshev
// distance; r: the resolution, o: the grid's origin). It is maximised by branch and bound over t on
// the cell lattice and ψ on a step that moves the farthest point by at most one cell from the
// nearest step (Hess et al., "Real-Time Loop
// Closure in 2D LIDAR SLAM", ICRA 2016, §V, with 3-D translation): a node of 2^k × 2^k × 2^k
// translations is bounded by the same sum over G_k, the max-pooled grid
//   G_k(c) = max { G₀(c + d) : d ∈ [0, 2^k)³ },
// so whole blocks of translations are discarded at once.
//
// The grid score only shortlists: a place cluttered with map points scores well under almost any
// submap, and the lattice puts the true pose up to half a cell off. Every distinct pose (farther
// than distinct_distance, or turned more than distinct_angle, from the others) scoring within
// candidate_margin of the best is refined by point-to-plane ICP in the same four degrees of
// freedom against planes fitted to the map's points,
//   min Σ_n ρ(n_nᵀ(Rz(ψ) q_n + t) + d_n),  ∂r/∂t = nᵀ,  ∂r/∂ψ = nᵀ(e_z × Rz(ψ) q_n),
// and scored by its fit, the mean over all points of max(0, 1 − r²/τ²) (τ = fit_residual; a point
// without a plane scores 0). The best fit must reach min_fit, and every other candidate must leave
// ambiguity_ratio times as many points unfitted (and fit ambiguity_margin worse). A corridor whose walls look the same along it, or a row of
// identical bays, leaves several: the answer is then "ambiguous" with the candidate count, and the
// caller gathers more data (a larger submap) before it asks again.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"

namespace fuse {

/// estimator.global_localization
struct GlobalLocalizationConfig {
  /// Search a loaded map for the start pose when none is given (fuse-run --load-map; false: the
  /// session starts at the map's origin, as a map made from the same start expects).
  bool enabled = true;
  double resolution = 0.25;        ///< m: cell of the finest score grid
  int levels = 5;                  ///< coarser grids above it: the largest node spans 2^levels cells a side
  double submap_radius = 25.0;     ///< m: submap points used around the sensor
  int max_points = 1500;           ///< submap points used at most (evenly thinned)
  double min_travel = 2.0;         ///< m: the sensor moves this far between searches ...
  double min_time = 3.0;           ///< s of data gathered before the first search of the whole map
  double period = 1.0;             ///< s of data between searches while the sensor does not move
  double min_score = 0.4;          ///< grid score S (above) a pose needs to be a candidate
  double candidate_margin = 0.2;   ///< regional maxima scoring within this of the best are refined and compared
  int max_candidates = 12;         ///< refined at most (the best scoring first)
  /// m: τ of the refined fit. A saved map is not rigid over the submap's 25 m: a map bent by its
  /// own drift (a few tenths of a degree) puts the submap's far points 0.15-0.3 m off its surfaces
  /// at the true pose (the corridor fixture: fit 0.91 for one scan, 0.81 for one second of scans at
  /// τ 0.15; 0.98 and 0.95 at τ 0.3).
  double fit_residual = 0.3;
  /// A location needs this refined fit (a floor and a ceiling alone fit 0.6-0.7). Within an
  /// initial pose's window it must also lie inside window_inner of the window (position and
  /// heading): a best pose at the window's edge says the truth lies beyond it, and the pose given
  /// is refused.
  double min_fit = 0.7;
  double window_inner = 0.75;
  /// Another candidate is a rival (the result is ambiguous) unless the points it leaves unfitted
  /// outnumber the best's by ambiguity_ratio, (1 − fit_r) ≥ ratio·(1 − fit_b), and its fit is at
  /// least ambiguity_margin lower. Floors, ceilings and plain walls fit anywhere alike; what
  /// tells places apart is in the few points that do not fit.
  double ambiguity_ratio = 3.0;
  double ambiguity_margin = 0.02;
  /// Around a given pose (a window with its σ), a candidate that fits worse than the best is no
  /// rival when the pose's prior makes it this much less likely: its squared Mahalanobis distance
  /// to the pose given exceeds the best's by more than this (6: a prior ratio below e^-3, 5 %).
  /// It never promotes a worse-fitting candidate, only lets the prior break a near tie (a corridor's
  /// door frames 3.5 m apart, the given pose 0.4 m from one of them).
  double window_prior_d2 = 6.0;
  double distinct_distance = 3.0;  ///< m: poses farther apart than this are distinct places ...
  double distinct_angle = 0.35;    ///< rad: ... as are poses turned more than this (20°)
  /// Searches of the whole map (no initial pose) that must agree, one after another, on where the
  /// session lies in the map (T_M_S within distinct_distance and distinct_angle) before it is
  /// taken: a place that happens to look like the submap from one spot rarely does from the next.
  int agreeing_searches = 2;
  /// rad: a map whose recorded gravity is farther than this from its −z is not searched (the
  /// search turns about z only; 2°: 0.9 m at the edge of a 25 m submap)
  double max_map_tilt = 0.035;
  double map_margin = 2.0;         ///< m: the translations searched: the map's bounding box grown by this
  /// Grid cells at most (bounding box / resolution³; six grids of a byte per cell): a larger map
  /// is searched at twice the resolution, and again, up to 4 m cells; beyond that it is refused.
  double max_cells = 2e7;
  /// Branch-and-bound nodes one search may score (a whole-map search of the corridor map scores
  /// ~1.5e5; a submap that fits nowhere, as after a bad jump, can need a thousand times that).
  /// Beyond it the search stops and answers "not found" (budget exhausted): never a location.
  double max_nodes = 3e6;
  /// s of data after a location is taken in which the scans must fit the map (tracking.min_fit) for
  /// it to be confirmed; a location that does not fit is dropped and the search goes on.
  double confirm_s = 1.0;
  /// s: a track lost this long in one episode (tracking status lost: the sensor was carried, a gap
  /// too long to coast, a wrong place taken) searches the whole map again ("lost and found");
  /// 0: never.
  double lost_search_after_s = 3.0;
  /// Wait for each search where it is asked for (fuse-run always sets it: an offline replay). false: it
  /// runs in a thread of its own and scan processing never waits for it.
  bool blocking = false;
  void load(ConfigNode& node);
};

/// A pose of the sensor in the map frame (position and heading about z) with its grid score S
/// and, once refined, its fit.
struct GlobalPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw = 0.0;
  double score = 0.0;
  double fit = 0.0;
};

/// Where to search: all of the map (no window), or around a requested pose.
struct SearchWindow {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< sensor position in the map
  double radius_xy = 1.0;                            ///< m
  double radius_z = 0.5;                             ///< m
  double yaw = 0.0;                                  ///< rad
  double yaw_range = 0.2;                            ///< rad either side
  /// The given pose's σ (0: unknown, no prior weighs the candidates).
  double sigma_xy = 0.0;                             ///< m
  double sigma_yaw = 0.0;                            ///< rad
};

struct GlobalSearchResult {
  enum class Verdict { kLocalized, kAmbiguous, kNotFound };
  Verdict verdict = Verdict::kNotFound;
  GlobalPose best;
  std::optional<GlobalPose> rival;  ///< the best distinct pose within the ambiguity margin, if any
  std::size_t candidates = 0;       ///< distinct poses within the margin of the best (itself included)
  double best_grid_score = 0.0;     ///< the highest S over the lattice (the branch and bound's optimum)
  std::size_t points = 0;           ///< submap points scored
  std::size_t nodes = 0;            ///< branch-and-bound nodes scored
  bool exhausted = false;           ///< stopped at max_nodes (the verdict is then "not found")
  double ms = 0.0;                  ///< wall time of the search
  std::string describe() const;
};
const char* to_string(GlobalSearchResult::Verdict v);

/// A 64-bit key of the cell of p in a grid of the given cell size (21 bits per axis): the submap's
/// one-point-per-cell thinning.
inline std::uint64_t cell_key(const Eigen::Vector3f& p, float inv_cell) {
  const Eigen::Vector3i k = (p * inv_cell).array().floor().cast<int>();
  return (static_cast<std::uint64_t>(k.x() & 0x1fffff) << 42) | (static_cast<std::uint64_t>(k.y() & 0x1fffff) << 21) |
         static_cast<std::uint64_t>(k.z() & 0x1fffff);
}

class GlobalLocalizer {
 public:
  /// Builds the score grids of a map (world-frame points, z up). Throws std::invalid_argument when
  /// the map is empty or its bounding box needs more than max_cells cells.
  GlobalLocalizer(const GlobalLocalizationConfig& config, const std::vector<Eigen::Vector3f>& map_points);

  /// Searches for the pose of a submap given relative to the sensor in a frame with z up and an
  /// unknown heading. Thread-safe (const): searches may run beside each other.
  GlobalSearchResult search(const std::vector<Eigen::Vector3f>& submap,
                            const std::optional<SearchWindow>& window = std::nullopt) const;
  /// S (above) of one pose: the search's leaf score of this submap (thinned as the search thins
  /// it), for checks and tests.
  double score(const std::vector<Eigen::Vector3f>& submap, const Eigen::Vector3d& position, double yaw) const;
  /// Refines a pose by the four-degree-of-freedom ICP above; the result carries its fit.
  GlobalPose refine(const std::vector<Eigen::Vector3f>& submap, const GlobalPose& start) const;

  /// The config in use (resolution: the one the map's size allowed).
  const GlobalLocalizationConfig& config() const { return config_; }
  Eigen::Vector3d grid_origin() const { return origin_; }
  Eigen::Vector3i grid_size() const { return size_; }

 private:
  struct Search;  // one search's state (global_localizer.cpp)
  /// G_level at cell c: the maximum of G₀ over [c, c + 2^level)³. A block that starts below the
  /// grid is bounded by the block at the grid's edge, which covers the part inside.
  std::uint8_t at(int level, Eigen::Vector3i c) const {
    const int span = 1 << level;
    for (int a = 0; a < 3; ++a) {
      if (c(a) + span - 1 < 0 || c(a) >= size_(a)) return 0;
      c(a) = std::max(c(a), 0);
    }
    return grids_[level][(static_cast<std::size_t>(c.z()) * size_.y() + c.y()) * size_.x() + c.x()];
  }

  GlobalLocalizationConfig config_;
  Eigen::Vector3d origin_;
  Eigen::Vector3i size_;
  std::vector<std::vector<std::uint8_t>> grids_;  ///< G_0 … G_levels
  std::shared_ptr<const SpatialIndex> index_;     ///< the map's points, for refine
};

}  // namespace fuse
