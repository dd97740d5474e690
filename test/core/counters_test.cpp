// Counters and their log rate limit: the first messages of a reason all pass, later ones at
// most one per interval, and the one that passes says how many it stands for.
#include <gtest/gtest.h>

#include <thread>

#include "fuse/core/counters.hpp"
#include "fuse/core/logging.hpp"

namespace fuse {
namespace {

TEST(LogRateLimit, FirstMessagesPassThenOnePerInterval) {
  LogRateLimit limit(std::chrono::hours(1));
  std::uint64_t suppressed = 99;
  for (std::uint64_t i = 0; i < LogRateLimit::kFirstMessages; ++i) {
    ASSERT_TRUE(limit.allow(suppressed));
    EXPECT_EQ(suppressed, 0u);
  }
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(limit.allow(suppressed));
}

TEST(LogRateLimit, AMessageAfterTheIntervalCountsWhatWasSuppressed) {
  LogRateLimit limit(std::chrono::milliseconds(1));
  std::uint64_t suppressed = 0;
  for (std::uint64_t i = 0; i < LogRateLimit::kFirstMessages; ++i) ASSERT_TRUE(limit.allow(suppressed));
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(limit.allow(suppressed));
  EXPECT_EQ(suppressed, 0u);  // nothing was held back between the two
  // Held back ones are counted once the interval has passed.
  LogRateLimit slow(std::chrono::milliseconds(50));
  // The interval runs from the last message let through, the last of the first ones: the clock
  // is read before them (read after, it could be up to their time short of the interval).
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t i = 0; i < LogRateLimit::kFirstMessages; ++i) ASSERT_TRUE(slow.allow(suppressed));
  int refused = 0;
  while (!slow.allow(suppressed)) ++refused;
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(50));
  EXPECT_EQ(suppressed, static_cast<std::uint64_t>(refused));
}

TEST(Counters, CountEveryOccurrenceWhateverIsLogged) {
  Counters c(logger("test"));
  for (int i = 0; i < 10000; ++i) c.count("disk_full", "cannot write");
  c.add("other", 3);
  EXPECT_EQ(c.get("disk_full"), 10000u);
  EXPECT_EQ(c.get("other"), 3u);
  EXPECT_EQ(c.get("never"), 0u);
}

}  // namespace
}  // namespace fuse
