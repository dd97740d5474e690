// Fixtures of the map server core tests: a config in a directory, scan-like observations whose
// overlap makes the policy's order matter, map comparisons, and a sender that follows
// fuse-update's rules (unacked_observations.hpp) against a MapServerCore.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <limits>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "fuse/map/map_server_core.hpp"

namespace fuse::test {

inline MapServerConfig config_in(const std::filesystem::path& dir, std::size_t snapshot_every = 0) {
  MapServerConfig config;
  config.directory = dir.string();
  config.chunk_size = 8.0;  // small chunks: a scan touches several, some with negative coordinates
  config.snapshot_every = snapshot_every;
  config.policy.min_point_distance = 0.3;
  return config;
}

/// A scan-like observation: points on the walls and floor of a corridor around x = 2·sequence - 15,
/// overlapping the previous scans so that the policy skips part of them.
inline std::vector<Eigen::Vector3f> scan(std::uint64_t session, std::uint64_t sequence, int n = 400) {
  std::mt19937 rng(static_cast<std::uint32_t>(session * 1000 + sequence));
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const float cx = 2.f * static_cast<float>(sequence) - 15.f;
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < n; ++i) {
    const float x = cx + 6.f * u(rng);
    switch (i % 3) {
      case 0: points.emplace_back(x, -2.f, 1.5f + 1.5f * u(rng)); break;
      case 1: points.emplace_back(x, 2.f, 1.5f + 1.5f * u(rng)); break;
      default: points.emplace_back(x, 2.f * u(rng), -0.5f); break;
    }
  }
  return points;
}

inline void expect_same_map(const PointMap& a, const PointMap& b) {
  EXPECT_EQ(a.chunk_size(), b.chunk_size());
  ASSERT_EQ(a.num_chunks(), b.num_chunks());
  ASSERT_EQ(a.num_points(), b.num_points());
  a.for_each_chunk([&](const PointChunk& ca) {
    const PointChunk* cb = b.chunk(ca.key);
    ASSERT_NE(cb, nullptr) << "chunk " << ca.coord.transpose();
    EXPECT_EQ(ca.revision, cb->revision) << "chunk " << ca.coord.transpose();
    EXPECT_EQ(ca.points, cb->points) << "chunk " << ca.coord.transpose();
  });
}

/// Fraction of reference's points that map holds too (the same coordinates), in [0, 1].
inline double shared_fraction(const PointMap& map, const PointMap& reference) {
  std::set<std::tuple<float, float, float>> held;
  map.for_each_chunk([&](const PointChunk& c) {
    for (const auto& p : c.points) held.emplace(p.x(), p.y(), p.z());
  });
  std::size_t shared = 0;
  reference.for_each_chunk([&](const PointChunk& c) {
    for (const auto& p : c.points) shared += held.count({p.x(), p.y(), p.z()});
  });
  return reference.num_points() == 0 ? 1.0 : static_cast<double>(shared) / static_cast<double>(reference.num_points());
}

/// One session's sender, as fuse-update is one: holds what is not acknowledged, tells the
/// lowest it holds with every observation, re-sends in order, gives up the oldest beyond
/// max_held. Observation q carries scan(session, q); `sent` observations were sent and
/// acknowledged before.
class Sender {
 public:
  Sender(MapServerCore& core, std::uint64_t session, std::uint64_t sent = 0,
         std::size_t max_held = std::numeric_limits<std::size_t>::max())
      : core_(&core), session_(session), max_held_(max_held), sent_(sent), acked_(sent) {}
  /// Sends to another core from now on (a restarted map server).
  void attach(MapServerCore& core) { core_ = &core; }

  MapApplyResult send_next() {
    const std::uint64_t q = ++sent_;
    held_.push_back(q);
    const MapApplyResult r = send(q);
    while (held_.size() > max_held_) {
      held_.pop_front();
      ++given_up_;
    }
    return r;
  }
  void resend_all() {
    const std::deque<std::uint64_t> held = held_;
    for (const std::uint64_t q : held) send(q);
  }
  /// The acknowledgement a status would carry now (the core's).
  void poll() { take(core_->acked(session_)); }

  std::uint64_t session() const { return session_; }
  std::uint64_t sent() const { return sent_; }
  std::uint64_t acked() const { return acked_; }
  std::size_t held() const { return held_.size(); }
  std::size_t given_up() const { return given_up_; }
  /// Every acknowledged sequence the core returned, in order.
  const std::vector<std::uint64_t>& acks_seen() const { return acks_seen_; }

 private:
  MapApplyResult send(std::uint64_t q) {
    const std::uint64_t lowest = held_.empty() ? q : held_.front();
    const MapApplyResult r = core_->apply(session_, q, 0.1 * static_cast<double>(q), scan(session_, q), lowest);
    take(r.acked);
    return r;
  }
  void take(std::uint64_t acked) {
    acks_seen_.push_back(acked);
    acked_ = std::max(acked_, acked);
    while (!held_.empty() && held_.front() <= acked_) held_.pop_front();
  }

  MapServerCore* core_;
  std::uint64_t session_;
  std::size_t max_held_;
  std::uint64_t sent_ = 0, acked_ = 0;
  std::size_t given_up_ = 0;
  std::deque<std::uint64_t> held_;
  std::vector<std::uint64_t> acks_seen_;
};

}  // namespace fuse::test
