#include "fuse/map/free_space_carver.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "fuse/association/associator.hpp"

namespace fuse {

namespace {
constexpr int kAzimuthPixels = 180, kElevationPixels = 90;  // 2° pixels
constexpr int kPixels = kAzimuthPixels * kElevationPixels;
constexpr float kPi = 3.14159265358979f;
constexpr float kPixelsPerRad = static_cast<float>(kAzimuthPixels) / (2.0f * kPi);
/// At most this many slices along the scan's path (each a range image of kPixels).
constexpr int kMaxSlices = 8;
/// A window reaches out this many pixels on each side at most (in elevation; twice that in
/// azimuth near the poles): a point nearer than that angle allows is tested against fewer rays.
constexpr int kMaxWindow = 6;
/// The plane around a young point, for the grazing test: its nearest map points (as many as the
/// association's default), within a voxel's reach, all within the association's default
/// plane thickness of the fitted plane.
constexpr int kPlanePoints = 5;
constexpr float kPlaneReach = 0.5f, kPlaneThickness = 0.1f;

/// atan2 within 0.0015 rad (0.09°, a twentieth of a pixel), without a libm call: atan on [0, 1]
/// by the rational-free approximation π/4·x − x(x − 1)(0.2447 + 0.0663x), then the octant.
float fast_atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float hi = std::max(ax, ay);
  if (hi == 0.0f) return 0.0f;
  const float q = std::min(ax, ay) / hi;
  float r = 0.25f * kPi * q - q * (q - 1.0f) * (0.2447f + 0.0663f * q);
  if (ay > ax) r = 0.5f * kPi - r;
  if (x < 0.0f) r = kPi - r;
  return y < 0.0f ? -r : r;
}

struct Pixel {
  int a, e;  ///< azimuth and elevation pixel
};
Pixel pixel_of(const Eigen::Vector3f& d) {
  const float az = fast_atan2(d.y(), d.x());
  const float el = fast_atan2(d.z(), std::sqrt(d.x() * d.x() + d.y() * d.y()));
  return {std::clamp(static_cast<int>((az + kPi) * kPixelsPerRad), 0, kAzimuthPixels - 1),
          std::clamp(static_cast<int>((el + 0.5f * kPi) * kPixelsPerRad), 0, kElevationPixels - 1)};
}

/// 1 / cos of the elevation farthest from the horizon among rows [e_lo, e_hi] (azimuth pixels
/// narrow towards the poles by cos(elevation)); capped where the window spans the circle anyway.
float inv_cos_rows(int e_lo, int e_hi) {
  const float centre = 0.5f * static_cast<float>(kElevationPixels);
  const float rows = std::max(std::abs(static_cast<float>(e_lo) - centre), std::abs(static_cast<float>(e_hi + 1) - centre));
  return 1.0f / std::max(std::cos(std::min(rows / kPixelsPerRad, 0.5f * kPi)), 0.1f);
}
}  // namespace

std::uint64_t FreeSpaceCarver::cell_of(const Eigen::Vector3f& p) const {
  // Three 21-bit cell coordinates, offset binary (±10⁶ cells: ±400 km at 0.4 m).
  const double inv = 1.0 / (2.0 * config_.radius);
  const auto c = [&](float v) {
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(static_cast<double>(v) * inv)) + (1 << 20)) &
           0x1FFFFF;
  };
  return c(p.x()) | (c(p.y()) << 21) | (c(p.z()) << 42);
}

void FreeSpaceCarver::expire(double t) {
  while (!young_.empty() && young_.front().t < t - config_.probation_s) young_.pop_front();
  // A cell is last hit no earlier than its youngest point was inserted: one not hit for
  // probation_s holds no young point any more. Swept that often.
  if (t < swept_t_ + config_.probation_s) return;
  swept_t_ = t;
  for (auto it = cell_index_.begin(); it != cell_index_.end();) {
    if (cells_[it->second].last < t - config_.probation_s) {
      free_cells_.push_back(it->second);
      it = cell_index_.erase(it);
    } else {
      ++it;
    }
  }
}

void FreeSpaceCarver::add(double t, const std::vector<Eigen::Vector3f>& inserted) {
  expire(t);  // scans that carve nothing (untrusted) still age the points
  for (const Eigen::Vector3f& p : inserted) {
    const std::uint64_t key = cell_of(p);
    auto [it, fresh] = cell_index_.try_emplace(key, 0);
    if (fresh) {
      if (free_cells_.empty()) {
        it->second = static_cast<std::uint32_t>(cells_.size());
        cells_.push_back({key, t, t});
      } else {
        it->second = free_cells_.back();
        free_cells_.pop_back();
        cells_[it->second] = {key, t, t};
      }
    } else {
      cells_[it->second].last = std::max(cells_[it->second].last, t);  // seen there again
    }
    young_.push_back({p, t, it->second});
  }
}

void FreeSpaceCarver::note_hits(double t, const std::vector<Eigen::Vector3f>& ends) {
  for (const Eigen::Vector3f& p : ends) {
    const auto it = cell_index_.find(cell_of(p));
    if (it != cell_index_.end()) cells_[it->second].last = std::max(cells_[it->second].last, t);
  }
}

void FreeSpaceCarver::bin_rays(const std::vector<Eigen::Vector3f>& ends, const std::vector<Eigen::Vector3f>& origins,
                               RayImage& image) {
  // The path's two ends: the origin farthest from the first one, and the one farthest from it.
  std::size_t ia = 0, ib = 0;
  for (std::size_t i = 0; i < origins.size(); ++i) {
    if ((origins[i] - origins[0]).squaredNorm() > (origins[ia] - origins[0]).squaredNorm()) ia = i;
  }
  for (std::size_t i = 0; i < origins.size(); ++i) {
    if ((origins[i] - origins[ia]).squaredNorm() > (origins[ib] - origins[ia]).squaredNorm()) ib = i;
  }
  const Eigen::Vector3f a = origins[ia];
  const Eigen::Vector3f path = origins[ib] - a;
  const float length = path.norm();
  // Slices no longer than the carve radius: a window widens by the slice's half length.
  const auto radius = static_cast<float>(config_.radius);
  image.slices = std::clamp(static_cast<int>(std::ceil(length / (2.0f * radius))), 1, kMaxSlices);
  const Eigen::Vector3f dir = length > 0.0f ? Eigen::Vector3f(path / length) : Eigen::Vector3f::Zero();
  for (int k = 0; k < image.slices; ++k) {
    image.slice_origin[k] = a + path * ((static_cast<float>(k) + 0.5f) / static_cast<float>(image.slices));
  }
  const auto slice_of = [&](const Eigen::Vector3f& o) {
    if (length <= 0.0f) return 0;
    const float f = (o - a).dot(dir) / length;
    return std::clamp(static_cast<int>(f * static_cast<float>(image.slices)), 0, image.slices - 1);
  };

  // Rays precomputed (unit direction, the farthest projection they carve), then binned by slice
  // and pixel with a counting sort.
  const auto beyond = static_cast<float>(1.0 + config_.beyond);
  const auto margin = static_cast<float>(config_.margin);
  image.start.assign(static_cast<std::size_t>(image.slices) * kPixels + 1, 0);
  bin_.resize(ends.size());
  std::vector<Ray>& rays = unsorted_;
  rays.resize(ends.size());
  image.slice_half = 0.0f;
  for (std::size_t i = 0; i < ends.size(); ++i) {
    const Eigen::Vector3f ray = ends[i] - origins[i];
    const float len = ray.norm();
    const int k = slice_of(origins[i]);
    image.slice_half = std::max(image.slice_half, (origins[i] - image.slice_origin[k]).norm());
    rays[i] = {origins[i], len > 0.0f ? Eigen::Vector3f(ray / len) : Eigen::Vector3f::Zero(), (len - margin) / beyond, len};
    const Pixel px = pixel_of(ends[i] - image.slice_origin[k]);
    bin_[i] = static_cast<std::uint32_t>(k * kPixels + px.e * kAzimuthPixels + px.a);
    ++image.start[bin_[i] + 1];
  }
  for (std::size_t q = 1; q < image.start.size(); ++q) image.start[q] += image.start[q - 1];
  cursor_.assign(image.start.begin(), image.start.end() - 1);
  image.rays.resize(ends.size());
  for (std::size_t i = 0; i < ends.size(); ++i) image.rays[cursor_[bin_[i]]++] = rays[i];
}

bool FreeSpaceCarver::steep_enough(const Eigen::Vector3f& c, const Eigen::Vector3f& u, const SpatialIndex& map,
                                   int& plane_state, Eigen::Vector3f& normal) const {
  if (plane_state == 0) {  // the plane around c, fitted once per point and scan
    Neighbors nb;
    map.knn(c, kPlanePoints, kPlaneReach, nb);
    float d = 0.0f;
    plane_state = nb.count >= kPlanePoints && fit_plane(nb.points, nb.count, kPlaneThickness, normal, d) ? 1 : 2;
  }
  if (plane_state == 2) return true;
  return std::abs(normal.dot(u)) >= static_cast<float>(std::sin(config_.min_incidence_deg * kPi / 180.0));
}

bool FreeSpaceCarver::carves(const Eigen::Vector3f& c, const RayImage& image, const SpatialIndex& map, int& plane_state,
                             Eigen::Vector3f& normal) const {
  const auto radius = static_cast<float>(config_.radius);
  const float r2 = radius * radius;
  const auto gap = static_cast<float>(config_.plane_gap);
  // Neither test carves c with a ray ending less than this beyond c's projection s onto it: the
  // surface test needs length − s_x ≥ gap with |s_x − s| < radius, the margin s < s_max ≤
  // length − margin. Checked before the plane around c is fitted.
  const float min_beyond = std::min(gap - radius, static_cast<float>(config_.margin));
  for (int k = 0; k < image.slices; ++k) {
    const Eigen::Vector3f d = c - image.slice_origin[k];
    const float range = d.norm();
    if (range <= radius + image.slice_half) continue;  // a ray this close to its start: too near to judge
    // Seen from the slice's origin, a ray passing within `radius` of c and starting within
    // slice_half of that origin points within (radius + slice_half) / (range − slice_half) of
    // c's direction where it passes c, and no farther out beyond it.
    const float angle = (radius + image.slice_half) / (range - image.slice_half);
    const Pixel pc = pixel_of(d);
    const int w = std::min(kMaxWindow, static_cast<int>(std::ceil(angle * kPixelsPerRad)));
    const int e_lo = std::max(0, pc.e - w), e_hi = std::min(kElevationPixels - 1, pc.e + w);
    const int wa = std::min(kAzimuthPixels / 2, static_cast<int>(std::ceil(static_cast<float>(w) * inv_cos_rows(e_lo, e_hi))));
    const std::uint32_t* start = image.start.data() + static_cast<std::size_t>(k) * kPixels;
    // A row's pixels are consecutive in the counting sort, so the rays of the window's part of
    // a row are one run (two where the window wraps around the azimuth's seam).
    const auto passes = [&](std::uint32_t first, std::uint32_t last) {
      for (std::uint32_t r = first; r < last; ++r) {
        const Ray& ray = image.rays[r];
        const Eigen::Vector3f oc = c - ray.o;
        const float s = oc.dot(ray.u);
        if (s <= 0.0f || oc.squaredNorm() - s * s >= r2) continue;  // the ray does not pass c
        if (ray.length - s <= min_beyond) continue;  // it ends before c or too little beyond to carve it
        const bool steep = steep_enough(c, ray.u, map, plane_state, normal);
        if (plane_state == 1) {
          // c lies on a plane (normal n): the ray must cross it within the radius of c, at
          // s_x = (c − o)·n / u·n, and end behind it by plane_gap, (length − s_x)·|u·n|. A ray
          // ending on c's own surface, or on another just in front of it, does not.
          const float un = ray.u.dot(normal);
          if (!steep || un == 0.0f) continue;  // parallel to the plane (min_incidence_deg 0): it crosses nothing
          const float s_x = oc.dot(normal) / un;
          if (s_x <= 0.0f || (ray.o + s_x * ray.u - c).squaredNorm() >= r2) continue;
          if ((ray.length - s_x) * std::abs(un) >= gap) return true;
          continue;
        }
        if (s < ray.s_max && steep) return true;  // c on no plane (an edge, a small object): the margin
      }
      return false;
    };
    const bool whole_row = 2 * wa + 1 >= kAzimuthPixels;
    const int a_lo = whole_row ? 0 : pc.a - wa, a_hi = whole_row ? kAzimuthPixels - 1 : pc.a + wa;
    for (int e = e_lo; e <= e_hi; ++e) {
      const std::uint32_t* row = start + e * kAzimuthPixels;
      if (a_lo < 0) {
        if (passes(row[a_lo + kAzimuthPixels], row[kAzimuthPixels]) || passes(row[0], row[a_hi + 1])) return true;
      } else if (a_hi >= kAzimuthPixels) {
        if (passes(row[a_lo], row[kAzimuthPixels]) || passes(row[0], row[a_hi - kAzimuthPixels + 1])) return true;
      } else if (passes(row[a_lo], row[a_hi + 1])) {
        return true;
      }
    }
  }
  return false;
}

const std::vector<Eigen::Vector3f>& FreeSpaceCarver::carve(double t, const std::vector<Eigen::Vector3f>& ends,
                                                           const std::vector<Eigen::Vector3f>& origins,
                                                           const SpatialIndex& map) {
  carved_.clear();
  expire(t);
  if (ends.empty() || origins.size() != ends.size()) return carved_;
  const bool remember = config_.lookback_s > 0.0;
  if (young_.empty() && !remember) return carved_;
  note_hits(t, ends);
  if (remember && !spare_.empty()) {  // reuse an old image's buffers
    image_ = std::move(spare_.back());
    spare_.pop_back();
  }
  bin_rays(ends, origins, image_);
  image_.t = t;
  // Every stride-th young point from a phase that turns with each scan: each is tested every
  // stride scans when there are more than max_tests.
  const std::size_t stride = std::max<std::size_t>(1, (young_.size() + config_.max_tests - 1) / config_.max_tests);
  const std::size_t phase = scans_++ % stride;
  std::size_t kept = 0;
  for (std::size_t j = 0; j < young_.size(); ++j) {
    const Young& y = young_[j];
    const Hits& cell = cells_[y.cell];
    if (cell.last - cell.first >= config_.release_s) {
      ++released_;  // hit again and again: a surface that stays
      continue;
    }
    int plane_state = 0;
    Eigen::Vector3f normal;
    if (j % stride == phase && carves(y.p, image_, map, plane_state, normal)) {
      carved_.push_back(y.p);
    } else {
      young_[kept++] = y;
    }
  }
  young_.resize(kept);
  if (remember) history_.push_back(std::move(image_));
  return carved_;
}

std::size_t FreeSpaceCarver::seen_empty(double t, const std::vector<Eigen::Vector3f>& points, const SpatialIndex& map,
                                        std::vector<std::uint8_t>& empty) {
  empty.assign(points.size(), 0);
  while (!history_.empty() && history_.front().t < t - config_.lookback_s) {
    spare_.push_back(std::move(history_.front()));
    history_.pop_front();
  }
  std::size_t earlier = history_.size();  // scans before t only
  while (earlier > 0 && history_[earlier - 1].t >= t) --earlier;
  if (earlier == 0 || points.empty()) return 0;
  // Bounded work: as many scans as lookback_tests point tests allow (one at least), spread over
  // the lookback from the newest (a place seen empty long before the mover came counts as much).
  const std::size_t scans = std::clamp<std::size_t>(config_.lookback_tests / points.size(), 1, earlier);
  const double step = scans > 1 ? static_cast<double>(earlier - 1) / static_cast<double>(scans - 1) : 0.0;
  std::size_t n = 0;
  Neighbors nb;
  for (std::size_t i = 0; i < points.size(); ++i) {
    // A point the map already has a point beside is where the map says something is (a wall
    // seen again, an edge): whatever a ray passing near it showed, it is not judged.
    map.knn(points[i], 1, static_cast<float>(config_.radius), nb);
    if (nb.count > 0) continue;
    int plane_state = 0;  // the plane around the point, fitted once for all the scans
    Eigen::Vector3f normal;
    for (std::size_t j = 0; j < scans; ++j) {
      const std::size_t k = earlier - 1 - static_cast<std::size_t>(std::lround(step * static_cast<double>(j)));
      if (carves(points[i], history_[k], map, plane_state, normal)) {
        empty[i] = 1;
        ++n;
        break;
      }
    }
  }
  return n;
}

}  // namespace fuse
