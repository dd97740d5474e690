// fuse-update's unacknowledged map observations (unacked_observations.hpp): bounded by count and
// bytes, the oldest given up and reported, lowest_unacked told with every send and re-send,
// re-sent in order, released by the map server's acknowledgement of our session.
#include "unacked_observations.hpp"

#include <gtest/gtest.h>

#include "fuse/service/system_config.hpp"

namespace fuse::service {
namespace {

using Clock = UnackedObservations::Clock;
using namespace std::chrono_literals;

constexpr std::size_t kPoints = 100;
constexpr std::size_t kBytes = kPoints * sizeof(fuse_msgs::Point3f);

fuse_msgs::MapObservation observation(std::uint64_t sequence, std::uint64_t lowest_unacked) {
  fuse_msgs::MapObservation o;
  o.session(42);
  o.sequence_number(sequence);
  o.lowest_unacked(lowest_unacked);
  o.points().resize(kPoints);
  return o;
}

/// Sends observations first..last as offer_to_map does; returns every sequence given up.
std::vector<std::uint64_t> send(UnackedObservations& held, std::uint64_t first, std::uint64_t last,
                                Clock::time_point at) {
  std::vector<std::uint64_t> given_up;
  for (std::uint64_t q = first; q <= last; ++q) {
    for (const std::uint64_t g : held.add(observation(q, held.lowest_unacked(q)), at)) given_up.push_back(g);
  }
  return given_up;
}

TEST(UnackedObservations, GivesUpTheOldestBeyondTheCountAndTellsTheLowestHeld) {
  UnackedObservations held({3, 1u << 30, 1.0});
  EXPECT_EQ(held.lowest_unacked(1), 1u) << "nothing held: the observation itself";
  EXPECT_EQ(send(held, 1, 5, Clock::now()), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(held.size(), 3u);
  EXPECT_EQ(held.bytes(), 3 * kBytes);
  EXPECT_EQ(held.lowest_unacked(6), 3u) << "1 and 2 were given up: the map server may settle them";
}

TEST(UnackedObservations, GivesUpTheOldestBeyondTheBytesButNeverTheNewest) {
  UnackedObservations held({1000, 2 * kBytes + kBytes / 2, 1.0});
  EXPECT_EQ(send(held, 1, 4, Clock::now()), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(held.size(), 2u);
  UnackedObservations tiny({1000, kBytes / 2, 1.0});
  EXPECT_EQ(send(tiny, 1, 3, Clock::now()), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(tiny.size(), 1u) << "the newest stays, whatever its size";
}

TEST(UnackedObservations, ReSendsInOrderWhenDueWithTheLowestBroughtUpToDate) {
  UnackedObservations held({1000, 1u << 30, 1.0});
  const auto t0 = Clock::now();
  send(held, 1, 5, t0);
  EXPECT_TRUE(held.due(t0 + 500ms, false).empty());
  held.acknowledge(2);
  EXPECT_EQ(held.size(), 3u);
  EXPECT_EQ(held.bytes(), 3 * kBytes);
  const auto due = held.due(t0 + 1500ms, false);
  ASSERT_EQ(due.size(), 3u);
  for (std::size_t i = 0; i < due.size(); ++i) {
    EXPECT_EQ(due[i].sequence_number(), 3 + i);
    EXPECT_EQ(due[i].lowest_unacked(), 3u);
  }
  EXPECT_TRUE(held.due(t0 + 3000ms, false).empty()) << "re-sent at 1.5 s: due again after 2 s (backoff)";
  EXPECT_EQ(held.due(t0 + 3600ms, false).size(), 3u);
  EXPECT_TRUE(held.due(t0 + 7000ms, false).empty()) << "re-sent twice: due again after 4 s";
  EXPECT_EQ(held.due(t0 + 7700ms, false).size(), 3u);
  for (int k = 0; k < 6; ++k) held.due(t0 + 7700ms + std::chrono::seconds(20 * (k + 1)), false);
  EXPECT_EQ(held.due(t0 + 127700ms + 16100ms, false).size(), 3u) << "the wait stops growing at 16 s";
  EXPECT_EQ(held.due(t0 + 143900ms, true).size(), 3u);
  EXPECT_EQ(held.due(t0 + 145000ms, false).size(), 3u) << "after a restarted map server: 1 s again";
  held.acknowledge(10);
  EXPECT_EQ(held.size(), 0u);
  EXPECT_EQ(held.bytes(), 0u);
}

TEST(UnackedObservations, FindsOurAcknowledgementInTheStatus) {
  fuse_msgs::MapStatus status;
  status.session(7);
  status.acked_sequence(70);
  EXPECT_EQ(UnackedObservations::acked_in(status, 7), 70u) << "a status without a list names its newest session";
  EXPECT_FALSE(UnackedObservations::acked_in(status, 42).has_value());
  fuse_msgs::SessionAck ours, other;
  ours.session(42);
  ours.acked_sequence(12);
  other.session(7);
  other.acked_sequence(70);
  status.sessions({other, ours});
  EXPECT_EQ(UnackedObservations::acked_in(status, 42), 12u) << "not the newest session, still listed";
}

TEST(UnackedObservations, BoundsComeFromTheUpdateConfig) {
  UpdateServiceConfig config;
  ConfigNode node = ConfigNode::from_string("max_unacked: 500\nmax_unacked_bytes: 67108864\n");
  config.load(node);
  EXPECT_EQ(config.max_unacked, 500u);
  EXPECT_EQ(config.max_unacked_bytes, 67108864u);
  for (const char* bad : {"max_unacked_bytes: 1000\n", "max_unacked_bytes: many\n", "max_unacked_byte: 67108864\n"}) {
    UpdateServiceConfig c;
    ConfigNode n = ConfigNode::from_string(bad);
    try {
      c.load(n);
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("max_unacked_byte"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace fuse::service
