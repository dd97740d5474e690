// Micro-benchmark of the spatial indexes (prints figures): a corridor-like map of points on
// surfaces grown by scans of ~1000 points, then per-scan work as the estimator does it —
// 3000 knn(k = 5, max_dist = 1.5 m) queries near the surfaces and one insert of 1000 points.
//   fuse_index_bench [map_points ...]   (default: 100000 1000000; --help for the options)
#include <chrono>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/cli/cli.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// A point on the floor, ceiling or a wall of a corridor 4 m wide and 3 m high along x in [x0, x0 + 10].
Eigen::Vector3f surface_point(std::mt19937& rng, float x0) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float x = x0 + 10.0f * u(rng);
  const float a = u(rng);
  const int face = static_cast<int>(4.0f * u(rng));
  switch (face) {
    case 0: return {x, -2.0f + 4.0f * a, 0.0f};
    case 1: return {x, -2.0f + 4.0f * a, 3.0f};
    case 2: return {x, -2.0f, 3.0f * a};
    default: return {x, 2.0f, 3.0f * a};
  }
}

std::vector<Eigen::Vector3f> scan(std::mt19937& rng, float x0, int n) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out.push_back(surface_point(rng, x0));
  return out;
}

/// One index type on a map of `n` points: build time, then kRounds of per-scan work.
void measure(const char* type, long n) {
  constexpr int kScan = 1000, kQueries = 3000, kRounds = 20;
  constexpr float kStep = 1.4f;
  fuse::SpatialIndexConfig cfg;
  cfg.type = type;
  auto index = fuse::make_spatial_index(cfg);
  std::mt19937 rng(1);
  // Grow the map scan by scan along the corridor: 1.4 m of new corridor per scan of 1000 points
  // keeps ~50 points/m² on the surfaces, about what a map with min_point_distance 0.15 m holds.
  const auto t0 = Clock::now();
  for (long done = 0, s = 0; done < n; done += kScan, ++s) index->insert(scan(rng, kStep * static_cast<float>(s), kScan));
  const double build_s = ms_since(t0) / 1000.0;
  const float head = kStep * static_cast<float>(n / kScan);
  double knn_ms = 0.0, insert_ms = 0.0;
  fuse::Neighbors nb;
  long found = 0;
  std::normal_distribution<float> noise(0.0f, 0.05f);
  for (int round = 0; round < kRounds; ++round) {
    auto qs = scan(rng, head - 5.0f, kQueries);
    for (auto& q : qs) q += Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
    const auto t1 = Clock::now();
    for (const auto& q : qs) {
      index->knn(q, 5, 1.5f, nb);
      found += nb.count;
    }
    knn_ms += ms_since(t1);
    const auto pts = scan(rng, head, kScan);
    const auto t2 = Clock::now();
    index->insert(pts);
    insert_ms += ms_since(t2);
  }
  std::printf("%-11s %9zu %12.2f %14.3f %14.3f %12.3f   (found %ld)\n", type, index->size(), build_s,
              knn_ms / kRounds, insert_ms / kRounds, 1000.0 * knn_ms / (kRounds * kQueries), found);
}

/// Parses argv into `sizes`. std::nullopt: go on; otherwise the exit code to end with.
std::optional<int> parse(int argc, char** argv, std::vector<long>& sizes) {
  const auto app = fuse::cli::make_app(
      "fuse_index_bench",
      "Spatial index micro-benchmark: per index type (ivox, kdtree, voxel_grid) and map size, the build time of "
      "a corridor map grown scan by scan, then 3000 knn(k = 5, 1.5 m) queries and one insert of 1000 points per "
      "scan (means over 20 scans).");
  app->add_option("map_points", sizes, "map sizes in points (default: 100000 1000000)")
      ->type_name("N");
  if (const std::optional<int> code = fuse::cli::parse(*app, argc, argv)) return code;
  for (const long n : sizes) {
    if (n <= 0) return fuse::cli::usage_error(*app, "map_points: " + std::to_string(n) + " is not a positive size");
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<long> sizes;
  if (const std::optional<int> code = parse(argc, argv, sizes)) return *code;
  if (sizes.empty()) sizes = {100000, 1000000};
  std::printf("%-11s %9s %12s %14s %14s %12s\n", "index", "points", "build_s", "knn3000_ms", "insert1000_ms",
              "us/query");
  for (long n : sizes) {
    for (const char* type : {"ivox", "kdtree", "voxel_grid"}) measure(type, n);
  }
  return 0;
}
