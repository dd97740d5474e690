// Functional role: localization on a saved map. Mapping on one traversal of the simulated
// corridor saves its map; a second traversal of the same world (same --world-seed, another
// --seed) is localized against it with the map frozen. The map file is byte-identical
// afterwards, the error is comparable to mapping on the second traversal, and it does not grow
// with the distance travelled: in the map frame, its error over the last third of the run stays
// within the map's own error there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "fuse/eval/alignment.hpp"
#include "fuse/eval/association.hpp"
#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/association/associator.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/map/map_storage.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
const std::string kFirst = std::string(FUSE_TEST_DATA) + "/corridor60";     // seed 1, world 1
const std::string kSecond = std::string(FUSE_TEST_DATA) + "/corridor60_b";  // seed 2, world 1
const std::string kElsewhere = std::string(FUSE_TEST_DATA) + "/corridor_start25";  // seed 5, world 1, 25 m along
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

std::string bytes_of(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

/// Position error in the map frame, per estimated pose. The map frame is the first traversal's
/// estimated frame: the truth is brought into it once, by the SE(3) alignment of the first
/// traversal's estimate (not of the run being checked), so a drift of the localization shows.
std::vector<double> errors_in_map_frame(const eval::Trajectory& est, const eval::Trajectory& gt, const eval::Similarity3& gt_to_map) {
  const auto assoc = eval::associate_by_time(eval::transform(gt, gt_to_map), est);
  std::vector<double> out;
  for (std::size_t i = 0; i < assoc.estimate.size(); ++i) out.push_back((assoc.reference[i].p - assoc.estimate[i].p).norm());
  return out;
}

TEST(Localization, OnASavedMapTheMapStaysUnchangedAndTheErrorDoesNotGrow) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap") && fs::exists(kSecond + "/recording.mcap")) << "fixtures missing";
  const std::string map_file = std::string(FUSE_TEST_OUT) + "/localization-map.snapshot";
  fs::create_directories(FUSE_TEST_OUT);
  RunnerConfig mapping = load_runner_config(kConfig);
  mapping.save_map = map_file;
  const RunSummary first = run_offline(mapping, kFirst + "/recording.mcap", "");
  ASSERT_TRUE(first.error.empty()) << first.error;
  const std::string before = bytes_of(map_file);
  ASSERT_GT(before.size(), 1000u);

  // Both traversals start at the same place: the second starts at the map's origin (no search).
  RunnerConfig localization =
      load_runner_config(kConfig, {"estimator.map.mode=localization", "estimator.global_localization.enabled=false"});
  localization.load_map = map_file;
  const RunSummary loc = run_offline(localization, kSecond + "/recording.mcap", "");
  ASSERT_TRUE(loc.error.empty()) << loc.error;
  EXPECT_EQ(bytes_of(map_file), before) << "the saved map changed";

  const RunSummary map2 = run_offline(load_runner_config(kConfig), kSecond + "/recording.mcap", "");
  ASSERT_TRUE(map2.error.empty()) << map2.error;
  const auto gt = eval::read_tum(kSecond + "/groundtruth.tum");
  const double ate_loc = eval::evaluate(gt, loc.trajectory).ate.rmse;
  const double ate_map = eval::evaluate(gt, map2.trajectory).ate.rmse;
  RecordProperty("ate_localization_m", std::to_string(ate_loc));
  RecordProperty("ate_mapping_m", std::to_string(ate_map));
  // Comparable: on this short piece both are about 1 cm; the localization inherits the first
  // traversal's map error, so a centimetre of slack. docs/evaluation.md has the full loops.
  EXPECT_LT(ate_loc, ate_map + 0.01);

  const auto gt_first = eval::read_tum(kFirst + "/groundtruth.tum");
  const auto first_assoc = eval::associate_by_time(gt_first, first.trajectory);
  const eval::Similarity3 gt_to_map =
      eval::align(first_assoc.estimate, first_assoc.reference, eval::AlignmentMode::kSE3);
  const auto errors = errors_in_map_frame(loc.trajectory, gt, gt_to_map);
  ASSERT_GT(errors.size(), 300u);
  // The map itself carries the first traversal's error, which grows along that run; the
  // localization must not add drift of its own: over the last third of the run, its error stays
  // within that of the map (the first traversal's estimate over its own last third) + 2 cm.
  auto max_of_last_third = [](const std::vector<double>& e) {
    double m = 0.0;
    for (std::size_t i = e.size() - e.size() / 3; i < e.size(); ++i) m = std::max(m, e[i]);
    return m;
  };
  const double loc_last = max_of_last_third(errors);
  const double map_last = max_of_last_third(errors_in_map_frame(first.trajectory, gt_first, gt_to_map));
  RecordProperty("max_error_last_third_localization_m", std::to_string(loc_last));
  RecordProperty("max_error_last_third_map_m", std::to_string(map_last));
  EXPECT_LT(loc_last, map_last + 0.02) << "the localization drifts away from the map";
  EXPECT_LT(loc_last, 0.1);
}

/// A map of the first traversal, saved once for the tests below, with the truth-to-map transform.
struct SavedMap {
  std::string file;
  eval::Similarity3 gt_to_map;
};
const SavedMap& saved_map() {
  static const SavedMap map = [] {
    SavedMap m;
    m.file = std::string(FUSE_TEST_OUT) + "/start-anywhere-map.snapshot";
    fs::create_directories(FUSE_TEST_OUT);
    RunnerConfig mapping = load_runner_config(kConfig);
    mapping.save_map = m.file;
    const RunSummary first = run_offline(mapping, kFirst + "/recording.mcap", "");
    EXPECT_TRUE(first.error.empty()) << first.error;
    const auto assoc = eval::associate_by_time(eval::read_tum(kFirst + "/groundtruth.tum"), first.trajectory);
    m.gt_to_map = eval::align(assoc.estimate, assoc.reference, eval::AlignmentMode::kSE3);
    return m;
  }();
  return map;
}

/// The walk that starts 25 m along the path, localized on the saved map; its largest position
/// error in the map frame (the truth brought there by the first traversal's alignment, not by its
/// own), over the poses it wrote.
struct Elsewhere {
  RunSummary run;
  double max_error = 0.0;
};
Elsewhere run_elsewhere(const std::optional<InitialPose>& pose, const std::string& mode = "localization",
                        const std::string& save_map = "") {
  const SavedMap& map = saved_map();
  // A search of the whole map every 3 s of data rather than every second: the same decisions,
  // a third of the time.
  RunnerConfig c = load_runner_config(kConfig, {"estimator.map.mode=" + mode, "estimator.global_localization.blocking=true",
                                                "estimator.global_localization.period=3", "estimator.global_localization.min_travel=4"});
  c.load_map = map.file;
  c.save_map = save_map;
  c.initial_pose = pose;
  Elsewhere e;
  e.run = run_offline(c, kElsewhere + "/recording.mcap", "");
  if (e.run.trajectory.empty()) return e;
  for (double err : errors_in_map_frame(e.run.trajectory, eval::read_tum(kElsewhere + "/groundtruth.tum"), map.gt_to_map)) {
    e.max_error = std::max(e.max_error, err);
  }
  return e;
}

/// The IMU's true pose at the walk's start in the map frame, moved by (dx, dy) and turned by dyaw.
InitialPose true_start(double dx, double dy, double dyaw, double std_xy, double std_yaw) {
  const eval::Trajectory gt = eval::transform(eval::read_tum(kElsewhere + "/groundtruth.tum"), saved_map().gt_to_map);
  const Eigen::Matrix3d R = gt.front().q.toRotationMatrix();
  InitialPose p;
  p.position = gt.front().p + Eigen::Vector3d(dx, dy, 0.0);
  p.yaw = std::atan2(R(1, 0), R(0, 0)) + dyaw;
  p.std_xy = std_xy;
  p.std_yaw = std_yaw;
  return p;
}

TEST(StartAnywhere, AnInitialPoseNearTheTruthIsCheckedAndUsed) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap") && fs::exists(kElsewhere + "/recording.mcap")) << "fixtures missing";
  const std::string before = bytes_of(saved_map().file);
  // 0.5 m and 5° off, given with σ of 1 m and 10° ("2D Pose Estimate").
  const Elsewhere e = run_elsewhere(true_start(0.5, -0.3, 5.0 * M_PI / 180.0, 1.0, 10.0 * M_PI / 180.0));
  EXPECT_TRUE(e.run.error.empty()) << e.run.error;
  EXPECT_FALSE(e.run.diverged) << e.run.divergence;
  ASSERT_TRUE(e.run.localized) << e.run.localization;
  EXPECT_FALSE(e.run.initial_pose_refused);
  ASSERT_GT(e.run.trajectory.size(), 200u);
  RecordProperty("max_error_m", std::to_string(e.max_error));
  RecordProperty("localized_after_s", std::to_string(e.run.localized_after_s));
  // Unaligned, in the map's frame: within the map's own error (the first traversal drifts by a
  // few centimetres over this stretch) and the search's cell.
  EXPECT_LT(e.max_error, 0.25);
  EXPECT_EQ(bytes_of(saved_map().file), before) << "localization changed the saved map";
}

std::vector<Eigen::Vector3f> points_of(const std::string& snapshot) {
  PointMap map;
  MapMeta meta;
  EXPECT_TRUE(MapStorage::read_snapshot_file(snapshot, map, meta).snapshot_ok) << snapshot;
  std::vector<Eigen::Vector3f> points;
  map.for_each_chunk([&](const PointChunk& c) { points.insert(points.end(), c.points.begin(), c.points.end()); });
  return points;
}

TEST(StartAnywhere, MappingAfterTheLocationExtendsTheMapWithoutASeam) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap") && fs::exists(kElsewhere + "/recording.mcap")) << "fixtures missing";
  const std::string extended = std::string(FUSE_TEST_OUT) + "/start-anywhere-extended.snapshot";
  const Elsewhere e =
      run_elsewhere(true_start(0.3, 0.3, 3.0 * M_PI / 180.0, 1.0, 10.0 * M_PI / 180.0), "mapping", extended);
  ASSERT_TRUE(e.run.localized) << e.run.localization;
  EXPECT_LT(e.max_error, 0.25);
  const std::vector<Eigen::Vector3f> old_points = points_of(saved_map().file), new_points = points_of(extended);
  ASSERT_GT(new_points.size(), old_points.size()) << "mapping after the location did not extend the map";
  // The same frame, no seam: the saved map is kept as it was, and what the second session added
  // next to it (within 1 m of an old point) lies on the old surfaces, not beside them: 95% of
  // those points within 0.1 m of the plane through their five nearest old points. (Nearest-point
  // distance says nothing here: the map policy adds only points farther than min_point_distance
  // from every old one.)
  SpatialIndexConfig ic;
  ic.type = "kdtree";
  const std::unique_ptr<SpatialIndex> old_index = make_spatial_index(ic);
  old_index->insert(old_points);
  std::vector<float> off_surface;
  std::size_t kept = 0;
  Neighbors nn;
  for (const Eigen::Vector3f& p : new_points) {
    old_index->knn(p, 5, 1.0f, nn);
    if (nn.count == 0) continue;
    if (nn.dist2[0] < 1e-12f) {
      ++kept;
      continue;
    }
    Eigen::Vector3f normal;
    float d = 0.0f;
    if (nn.count < 5 || !fit_plane(nn.points, nn.count, 0.1f, normal, d)) continue;
    off_surface.push_back(std::abs(normal.dot(p) + d));
  }
  EXPECT_EQ(kept, old_points.size()) << "points of the saved map were lost or moved";
  ASSERT_GT(off_surface.size(), 100u);
  std::sort(off_surface.begin(), off_surface.end());
  const float p95 = off_surface[off_surface.size() * 95 / 100];
  RecordProperty("added_points", std::to_string(new_points.size() - old_points.size()));
  RecordProperty("added_off_old_surface_p95_m", std::to_string(p95));
  EXPECT_LT(p95, 0.1f);
}

TEST(StartAnywhere, TheSavedMapRecordsItsGravityAndATiltedOneIsNotSearched) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap")) << "fixtures missing";
  PointMap map;
  MapMeta meta;
  ASSERT_TRUE(MapStorage::read_snapshot_file(saved_map().file, map, meta).snapshot_ok);
  ASSERT_TRUE(meta.gravity.has_value()) << "fuse-run --save-map records the map frame's gravity";
  const double tilt = std::acos(std::clamp(-meta.gravity->z(), -1.0, 1.0));
  RecordProperty("map_gravity_tilt_deg", std::to_string(tilt * 180.0 / M_PI));
  EXPECT_LT(tilt, 1.0 * M_PI / 180.0);  // the frame is gravity-aligned at its start; estimated gravity moves little
  // The same map said to be tilted by 5°: the search, which turns about z only, refuses it.
  meta.gravity = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -1);
  const std::string tilted = std::string(FUSE_TEST_OUT) + "/start-anywhere-tilted.snapshot";
  MapStorage::write_snapshot_file(tilted, map, meta);
  RunnerConfig c = load_runner_config(kConfig, {"estimator.map.mode=localization"});
  c.load_map = tilted;
  const RunSummary run = run_offline(c, kElsewhere + "/recording.mcap", "");
  EXPECT_NE(run.error.find("gravity"), std::string::npos) << run.error;
}

TEST(StartAnywhere, AWrongInitialPoseIsRefusedNotTaken) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap") && fs::exists(kElsewhere + "/recording.mcap")) << "fixtures missing";
  // 2 m and 30° off, given with σ of 0.3 m and 3°: nothing within its window fits.
  const Elsewhere e = run_elsewhere(true_start(2.0, 0.0, 30.0 * M_PI / 180.0, 0.3, 3.0 * M_PI / 180.0));
  EXPECT_TRUE(e.run.initial_pose_refused) << e.run.localization;
  // After the refusal the whole map is searched: a location found must be the right one; none is
  // an exit code 3 ("not localized"), never poses in a wrong place.
  if (e.run.localized) {
    EXPECT_LT(e.max_error, 0.25);
  } else {
    EXPECT_TRUE(e.run.diverged);
    EXPECT_NE(e.run.divergence.find("not localized"), std::string::npos) << e.run.divergence;
    EXPECT_TRUE(e.run.trajectory.empty());
  }
}

TEST(StartAnywhere, WithoutAPoseAWrongLocationIsNeverReported) {
  ASSERT_TRUE(fs::exists(kFirst + "/recording.mcap") && fs::exists(kElsewhere + "/recording.mcap")) << "fixtures missing";
  const Elsewhere e = run_elsewhere(std::nullopt);
  RecordProperty("localized", e.run.localized ? "yes" : "no");
  RecordProperty("searches", std::to_string(e.run.searches));
  EXPECT_GT(e.run.searches, 0u);
  if (e.run.localized) {
    EXPECT_LT(e.max_error, 0.25);
  } else {
    EXPECT_TRUE(e.run.diverged);
    EXPECT_TRUE(e.run.trajectory.empty());
  }
}

}  // namespace
}  // namespace fuse
