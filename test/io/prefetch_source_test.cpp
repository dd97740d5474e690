// PrefetchSource: same events in the same order, errors in their place, bounded read-ahead,
// counters as delivered.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "fuse/io/prefetch_source.hpp"

namespace fuse::io {
namespace {

/// n IMU events at t = 0, 1, ...; throws InputError instead of event `fail_at` when given.
class CountingSource : public SensorSource {
 public:
  CountingSource(int n, int fail_at, std::atomic<int>& reads, int refuse_every = 0)
      : n_(n), fail_at_(fail_at), refuse_every_(refuse_every), reads_(reads) {}
  bool next(SensorEvent& out) override {
    const int i = reads_++;
    if (i == fail_at_) throw InputError("record " + std::to_string(i) + " is damaged");
    if (i >= n_) return false;
    if (refuse_every_ > 0 && i % refuse_every_ == 0) {  // refused before the event it returns
      ++stats_.imu_refused;
      ++stats_.rejected["odd_sample"];
    }
    out = SensorEvent{};
    out.kind = SensorEvent::Kind::kImu;
    out.imu.t = i;
    ++stats_.imu_samples;
    return true;
  }
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return Eigen::Isometry3d::Identity(); }
  const SourceStats& stats() const override { return stats_; }
  std::string describe() const override { return "counting"; }

 private:
  int n_, fail_at_, refuse_every_;
  std::atomic<int>& reads_;
  SourceStats stats_;
};

TEST(PrefetchSource, GivesEveryEventInOrderThenEnds) {
  std::atomic<int> reads{0};
  PrefetchSource source(std::make_unique<CountingSource>(1000, -1, reads), 16);
  EXPECT_EQ(source.describe(), "counting");
  ASSERT_TRUE(source.T_imu_lidar().has_value());
  SensorEvent ev;
  for (int i = 0; i < 1000; ++i) {
    ASSERT_TRUE(source.next(ev)) << i;
    EXPECT_EQ(ev.imu.t, i);
  }
  EXPECT_FALSE(source.next(ev));
  EXPECT_FALSE(source.next(ev));
  EXPECT_EQ(source.stats().imu_samples, 1000u);
}

TEST(PrefetchSource, ReadsAheadAtMostItsCapacity) {
  std::atomic<int> reads{0};
  PrefetchSource source(std::make_unique<CountingSource>(1000, -1, reads), 8);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  // 8 queued, and at most one more read in progress until the consumer takes one.
  EXPECT_GE(reads.load(), 8);
  EXPECT_LE(reads.load(), 9);
  SensorEvent ev;
  ASSERT_TRUE(source.next(ev));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_LE(reads.load(), 10);
}

TEST(PrefetchSource, CountsWhatWasDeliveredNotWhatWasReadAhead) {
  // The reader runs up to 64 events ahead; the counters follow the consumer: after event i the
  // source has read i + 1 samples and refused one before every 10th.
  std::atomic<int> reads{0};
  PrefetchSource source(std::make_unique<CountingSource>(200, -1, reads, 10), 64);
  SensorEvent ev;
  for (int i = 0; i < 200; ++i) {
    ASSERT_TRUE(source.next(ev));
    const SourceStats s = source.stats();
    ASSERT_EQ(s.imu_samples, static_cast<std::uint64_t>(i + 1));
    ASSERT_EQ(s.imu_refused, static_cast<std::uint64_t>(i / 10 + 1));
    ASSERT_EQ(s.rejected.at("odd_sample"), s.imu_refused);
  }
  EXPECT_FALSE(source.next(ev));
  EXPECT_EQ(source.stats().imu_samples, 200u);
  EXPECT_EQ(source.stats().imu_refused, 20u);
}

TEST(PrefetchSource, RaisesTheInnerErrorAfterTheEventsBeforeIt) {
  std::atomic<int> reads{0};
  PrefetchSource source(std::make_unique<CountingSource>(100, 5, reads), 64);
  SensorEvent ev;
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(source.next(ev));
  EXPECT_THROW(source.next(ev), InputError);
}

TEST(PrefetchSource, StopsReadingWhenDestroyedEarly) {
  std::atomic<int> reads{0};
  {
    PrefetchSource source(std::make_unique<CountingSource>(1000000, -1, reads), 4);
    SensorEvent ev;
    ASSERT_TRUE(source.next(ev));
  }
  EXPECT_LT(reads.load(), 10);
}

TEST(PrefetchSource, RefusesNoSourceAndZeroCapacity) {
  std::atomic<int> reads{0};
  EXPECT_THROW(PrefetchSource(nullptr, 4), std::invalid_argument);
  EXPECT_THROW(PrefetchSource(std::make_unique<CountingSource>(1, -1, reads), 0), std::invalid_argument);
}

}  // namespace
}  // namespace fuse::io
