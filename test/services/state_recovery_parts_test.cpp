// The pieces the restart rules rest on, without processes: fuse-state's checkpoint file (round
// trip, and every way it can be untrustworthy), fuse-update's scan backlog (bound, order,
// compaction that keeps what the LiDAR step keeps) and the history slice it is served (entry
// steps travel with their entries).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <thread>

#include "fuse/association/voxel_filter.hpp"
#include "fuse/service/scan_backlog.hpp"
#include "fuse/service/state_checkpoint.hpp"

namespace fuse::service {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(FUSE_TEST_OUT) / "state_recovery_parts";
  fs::create_directories(dir);
  const fs::path p = dir / name;
  fs::remove(p);
  return p;
}

Posterior some_posterior(double t) {
  Posterior post;
  post.t = t;
  post.scan_sequence = 42;
  post.x.p = Eigen::Vector3d(1.5, -2.25, 0.125);
  post.x.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  post.x.v = Eigen::Vector3d(0.5, 0.1, -0.02);
  post.x.bg = Eigen::Vector3d(1e-3, -2e-3, 5e-4);
  post.x.ba = Eigen::Vector3d(0.02, 0.01, -0.03);
  post.x.g = Eigen::Vector3d(0.01, -0.02, -9.81);
  std::mt19937 rng(7);
  std::normal_distribution<double> n;
  Eigen::MatrixXd A(kStateDim, kStateDim);
  for (int r = 0; r < kStateDim; ++r)
    for (int c = 0; c < kStateDim; ++c) A(r, c) = 1e-2 * n(rng);
  post.P = A * A.transpose() + 1e-6 * StateCovariance::Identity();
  return post;
}

TEST(StateCheckpoint, RoundTripKeepsThePosteriorExactly) {
  const fs::path file = scratch("roundtrip.ckpt");
  Checkpoint written;
  written.posterior = some_posterior(1234.5678);
  written.map_drift = written.posterior.P.topLeftCorner<6, 6>() * 0.25;
  written.frame = WorldFrame{fuse_msgs::MAP_FRAME_CONFIRMING, 7};  // a session confirming its place in a saved map
  const Posterior& in = written.posterior;
  write_checkpoint(file, written);
  std::string why;
  const auto read = read_checkpoint(file, why);
  ASSERT_TRUE(read) << why;
  EXPECT_EQ(read->map_drift, written.map_drift);
  EXPECT_EQ(read->frame.state, fuse_msgs::MAP_FRAME_CONFIRMING);
  EXPECT_EQ(read->frame.epoch, 7u);
  const Posterior* out = &read->posterior;
  EXPECT_EQ(out->t, in.t);
  EXPECT_EQ(out->x.p, in.x.p);
  EXPECT_LT((out->x.R - in.x.R).norm(), 1e-15);  // travels as a quaternion
  EXPECT_EQ(out->x.v, in.x.v);
  EXPECT_EQ(out->x.bg, in.x.bg);
  EXPECT_EQ(out->x.ba, in.x.ba);
  EXPECT_EQ(out->x.g, in.x.g);
  EXPECT_EQ(out->P, in.P);
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
}

TEST(StateCheckpoint, AnUntrustworthyFileIsRefusedWithTheReason) {
  std::string why;
  EXPECT_FALSE(read_checkpoint(scratch("missing.ckpt"), why));
  EXPECT_NE(why.find("no checkpoint"), std::string::npos) << why;

  const fs::path file = scratch("damaged.ckpt");
  write_checkpoint(file, Checkpoint{some_posterior(10.0), PoseCovariance::Identity(), {}});
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  auto write = [&](const std::string& b) { std::ofstream(file, std::ios::binary | std::ios::trunc) << b; };

  std::string flipped = bytes;
  flipped[flipped.size() / 2] ^= 0x40;
  write(flipped);
  EXPECT_FALSE(read_checkpoint(file, why));
  EXPECT_NE(why.find("damaged"), std::string::npos) << why;

  write(bytes.substr(0, bytes.size() - 10));
  EXPECT_FALSE(read_checkpoint(file, why));
  EXPECT_NE(why.find("damaged"), std::string::npos) << why;

  std::string other_version = bytes;
  other_version[8] = 9;
  write(other_version);
  EXPECT_FALSE(read_checkpoint(file, why));
  EXPECT_NE(why.find("version"), std::string::npos) << why;

  write("not a checkpoint at all");
  EXPECT_FALSE(read_checkpoint(file, why));
  EXPECT_NE(why.find("not a fuse-state checkpoint"), std::string::npos) << why;

  write(bytes);
  EXPECT_TRUE(read_checkpoint(file, why)) << why;
}

TEST(StateCheckpoint, WriterKeepsTheNewestAndCountsFailures) {
  const fs::path file = scratch("writer.ckpt");
  {
    CheckpointWriter writer(file, 0.01);
    for (int i = 1; i <= 50; ++i) writer.offer(Checkpoint{some_posterior(i), PoseCovariance::Zero(), {}});
    writer.offer(Checkpoint{some_posterior(3.0), PoseCovariance::Zero(), {}});  // older than what was offered: ignored
  }  // the destructor writes what is pending
  std::string why;
  const auto out = read_checkpoint(file, why);
  ASSERT_TRUE(out) << why;
  EXPECT_EQ(out->posterior.t, 50.0);

  CheckpointWriter broken(scratch("no-such-dir") / "x.ckpt", 0.01);
  broken.offer(Checkpoint{some_posterior(1.0), PoseCovariance::Zero(), {}});
  for (int i = 0; i < 500 && broken.failures() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(broken.failures(), 1u);
  EXPECT_NE(broken.last_error().find("cannot write checkpoint"), std::string::npos) << broken.last_error();
}

LidarScan synthetic_scan(double t_end, std::uint64_t seq, int n = 5000) {
  LidarScan s;
  s.t_start = t_end - 0.1;
  s.t_end = t_end;
  s.sequence = seq;
  std::mt19937 rng(static_cast<unsigned>(seq));
  std::uniform_real_distribution<float> u(-20.f, 20.f);
  for (int i = 0; i < n; ++i) {
    LidarPoint p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = 0.1f * u(rng);
    p.t_rel = 0.1f * static_cast<float>(i) / static_cast<float>(n);
    s.points.push_back(p);
  }
  return s;
}

// A slice entry keeps its step (a coasted gap's variance and levelling) across the wire, so that
// fuse-update re-propagating its slice from a newer posterior (bring_up_to_date) applies it as
// fuse-state does; a step that is not a variance is refused with the reason.
TEST(HistorySlice, EntryStepsRoundTripAndBadOnesAreRefused) {
  StateHistory::Entry e;
  e.t = 12.5;
  e.x = some_posterior(12.5).x;
  e.gyro = Eigen::Vector3d(0.1, 0.2, 0.3);
  e.accel = Eigen::Vector3d(0.4, 0.5, 9.6);
  e.gyro_smooth = Eigen::Vector3d(0.12, 0.18, 0.27);
  for (int i = 0; i < kStateDim; ++i) e.step.q(i) = 1e-3 * (i + 1);
  e.step.level_accel = Eigen::Vector3d(0.2, -0.1, 9.7);
  e.step.level_sigma = 0.1;
  e.step.coast_from = 9.25;
  e.step.coast_accel_std = 1.5;
  e.step.coast_gyro_std = 0.4;
  e.coasting = true;
  const StateHistory::Entry back = from_msg(to_msg(e));
  EXPECT_EQ(back.step.coast_from, e.step.coast_from);
  EXPECT_EQ(back.step.coast_accel_std, e.step.coast_accel_std);
  EXPECT_EQ(back.step.coast_gyro_std, e.step.coast_gyro_std);
  EXPECT_TRUE(back.coasting);
  EXPECT_EQ(back.gyro_smooth, e.gyro_smooth);  // the time offset's column reads it (re-propagation)
  EXPECT_EQ(back.step.q, e.step.q);
  EXPECT_EQ(back.step.level_accel, e.step.level_accel);
  EXPECT_EQ(back.step.level_sigma, e.step.level_sigma);
  StateHistory::Entry plain = e;
  plain.step = EntryStep{};
  EXPECT_TRUE(from_msg(to_msg(plain)).step.empty());
  EXPECT_TRUE(to_msg(plain).step_q().empty());  // entries without a step carry no variance

  fuse_msgs::HistoryEntry bad = to_msg(e);
  bad.step_q().pop_back();
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.step_q()[4] = -1.0;
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.step_level_sigma(std::nan(""));
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.step_coast_gyro_std(-0.1);
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.gyro_smooth().y(std::nan(""));
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.step_coast_from(std::numeric_limits<double>::infinity());
  EXPECT_THROW(from_msg(bad), InvalidSample);
  bad = to_msg(e);
  bad.step_coast_from(e.t + 1.0);  // a coast that starts after the entry it ends at
  EXPECT_THROW(from_msg(bad), InvalidSample);
}

TEST(ScanBacklog, HoldsAtMostTheConfiguredSpanInOrder) {
  PreprocessConfig pre;
  ScanBacklog backlog(pre, 2.0);
  std::size_t dropped = 0;
  for (int k = 1; k <= 50; ++k) dropped += backlog.push(synthetic_scan(100.0 + 0.1 * k, k, 10));
  EXPECT_LE(backlog.span_s(), 2.0 + 1e-9);
  EXPECT_EQ(dropped + backlog.size(), 50u);
  EXPECT_EQ(backlog.size(), 20u);  // 2 s of 0.1 s scans
  EXPECT_EQ(backlog.front().sequence, 31u);
  LidarScan first = backlog.take_front();
  EXPECT_EQ(first.sequence, 31u);
  backlog.return_front(std::move(first));
  EXPECT_EQ(backlog.front().sequence, 31u);
  EXPECT_EQ(backlog.size(), 20u);
}

TEST(ScanBacklog, CompactionKeepsWhatTheLidarStepKeeps) {
  PreprocessConfig pre;
  pre.min_range = 1.0;
  pre.max_range = 15.0;
  pre.voxel_size = 0.5;
  ScanBacklog backlog(pre, 100.0);
  const LidarScan raw = synthetic_scan(10.0, 1);
  backlog.push(raw);
  backlog.push(synthetic_scan(10.1, 2));
  EXPECT_EQ(backlog.compact_waiting(1), 1u);  // the first one goes next, as it is
  EXPECT_EQ(backlog.compact_waiting(1), 0u);  // compacted once
  EXPECT_EQ(backlog.front().points.size(), raw.points.size());
  backlog.pop_front();
  const LidarScan compacted = backlog.take_front();
  // Oracle: the LiDAR step's first stage on the raw scan (range filter, voxel filter).
  const LidarScan raw2 = synthetic_scan(10.1, 2);
  std::vector<Eigen::Vector3f> xyz;
  std::vector<std::uint32_t> idx, kept;
  for (std::uint32_t i = 0; i < raw2.points.size(); ++i) {
    const Eigen::Vector3f v(raw2.points[i].x, raw2.points[i].y, raw2.points[i].z);
    if (v.norm() < pre.min_range || v.norm() > pre.max_range) continue;
    xyz.push_back(v);
    idx.push_back(i);
  }
  VoxelFilter filter;
  filter.filter(xyz, static_cast<float>(pre.voxel_size), kept);
  ASSERT_EQ(compacted.points.size(), kept.size());
  ASSERT_LT(compacted.points.size(), raw2.points.size() / 2);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    EXPECT_EQ(compacted.points[k].x, raw2.points[idx[kept[k]]].x);
    EXPECT_EQ(compacted.points[k].t_rel, raw2.points[idx[kept[k]]].t_rel);
  }
  // Filtering the compacted scan again keeps every point: the step sees the same points.
  std::vector<Eigen::Vector3f> again;
  for (const LidarPoint& p : compacted.points) again.emplace_back(p.x, p.y, p.z);
  filter.filter(again, static_cast<float>(pre.voxel_size), kept);
  EXPECT_EQ(kept.size(), again.size());
}

}  // namespace
}  // namespace fuse::service
