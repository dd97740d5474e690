// The acknowledgement rule (session_acks.hpp): contiguous over durable sequences, holes
// remembered, the sender's lowest unacknowledged sequence settling what it gave up, activity
// order, merge.
#include "fuse/map/session_acks.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>

namespace fuse {
namespace {

TEST(SessionAcks, AcknowledgesOnlyUpToTheFirstHole) {
  SessionAcks acks;
  acks.add_durable(7, 1);
  acks.add_durable(7, 2);
  acks.add_durable(7, 4);
  acks.add_durable(7, 5);
  EXPECT_EQ(acks.acked(7), 2u);
  EXPECT_TRUE(acks.covered(7, 4));
  EXPECT_TRUE(acks.covered(7, 5));
  EXPECT_FALSE(acks.covered(7, 3));
  EXPECT_FALSE(acks.covered(7, 6));
  EXPECT_EQ(acks.missing(7), 1u);
  acks.add_durable(7, 3);  // the hole is filled: acknowledged through the run above it
  EXPECT_EQ(acks.acked(7), 5u);
  EXPECT_TRUE(acks.sessions().at(7).durable_above.empty());
  EXPECT_EQ(acks.acked(8), 0u) << "another session";
}

TEST(SessionAcks, LowestUnackedSettlesWhatTheSenderGaveUp) {
  SessionAcks acks;
  acks.add_durable(3, 103);
  EXPECT_EQ(acks.acked(3), 0u) << "a map server that never saw the session's start acknowledges nothing alone";
  acks.raise_floor(3, 101);  // the sender holds nothing below 101
  EXPECT_EQ(acks.acked(3), 100u);
  acks.raise_floor(3, 0);  // not said
  acks.raise_floor(3, 50);  // stale: floors never go back
  EXPECT_EQ(acks.acked(3), 100u);
  acks.raise_floor(3, 103);  // 101 and 102 given up: 103 is durable
  EXPECT_EQ(acks.acked(3), 103u);
  acks.add_durable(3, 105);
  acks.add_durable(3, 107);
  acks.raise_floor(3, 106);  // inside the durable ranges: acknowledged through 105, not over 106
  EXPECT_EQ(acks.acked(3), 105u);
  EXPECT_TRUE(acks.covered(3, 107));
}

TEST(SessionAcks, MatchesABruteForceModelInAnyOrder) {
  std::mt19937 rng(5);
  for (int round = 0; round < 200; ++round) {
    SessionAcks acks;
    std::set<std::uint64_t> settled;  // durable or below a floor
    std::uint64_t floor = 0;
    for (int step = 0; step < 60; ++step) {
      const std::uint64_t q = 1 + rng() % 40;
      if (rng() % 5 == 0) {
        acks.raise_floor(1, q);
        floor = std::max(floor, q - 1);
      } else {
        acks.add_durable(1, q);
        settled.insert(q);
      }
      std::uint64_t expected = floor;
      while (settled.count(expected + 1) > 0) ++expected;
      ASSERT_EQ(acks.acked(1), expected) << "round " << round << " step " << step;
      for (std::uint64_t s = 1; s <= 41; ++s) {
        ASSERT_EQ(acks.covered(1, s), s <= expected || settled.count(s) > 0) << s;
      }
    }
  }
}

TEST(SessionAcks, RestoreMergeAndActivityOrder) {
  SessionAcks a;
  a.add_durable(1, 1);
  a.add_durable(2, 1);
  a.add_durable(2, 3);
  a.touch(1);
  EXPECT_EQ(a.by_activity(), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(a.recent(1), (std::vector<std::pair<std::uint64_t, std::uint64_t>>{{1, 1}}));

  SessionAcks b;
  b.restore(2, 2, {{5, 6}});
  b.restore(9, 4, {});
  b.merge(a);  // a's sessions become the most recent, acknowledgements never go back
  EXPECT_EQ(b.acked(2), 3u) << "max(2 restored, 1..3 durable)";
  EXPECT_TRUE(b.covered(2, 5));
  EXPECT_TRUE(b.covered(2, 6));
  EXPECT_EQ(b.acked(9), 4u);
  EXPECT_EQ(b.by_activity(), (std::vector<std::uint64_t>{1, 2, 9}));

  SessionAcks restored;
  restored.restore(2, 3, {{5, 6}});
  restored.restore(9, 4, {});
  restored.restore(1, 1, {});
  EXPECT_EQ(restored, b);
}

}  // namespace
}  // namespace fuse
