// fuse-launch's progress line (fuse/launch/replay_progress.hpp): the share of the input's samples
// fuse-ingest published and the time left when the input says its size, otherwise what is known
// (sensor time, scans, poses, rate against real time) and that the size is not.
#include "fuse/launch/replay_progress.hpp"

#include <gtest/gtest.h>

namespace fuse::launch {
namespace {

ReplaySnapshot snapshot(std::uint64_t events, std::uint64_t scans, std::uint64_t poses, double t,
                        const std::string& tracking) {
  ReplaySnapshot s;
  s.events = events;
  s.scans = scans;
  s.poses = poses;
  s.sensor_t = t;
  s.tracking = tracking;
  return s;
}

TEST(ReplayProgress, KnownSizeGivesPercentageTimeLeftAndWhatTheBusShowed) {
  ReplayProgress p(1000);
  p.update(snapshot(0, 0, 0, 100.0, ""));  // the first scan answered: where the sensor time starts
  const std::string line = p.line(snapshot(250, 25, 20, 110.0, "running"), 5.0);
  EXPECT_NE(line.find("25 % (250 of 1000)"), std::string::npos) << line;
  EXPECT_NE(line.find("10.0 s of data (2.0x real time)"), std::string::npos) << line;
  EXPECT_NE(line.find("about 15 s left"), std::string::npos) << line;
  EXPECT_NE(line.find("25 scans replayed, 20 poses, fuse-state running"), std::string::npos) << line;
  EXPECT_EQ(line.find("unknown"), std::string::npos) << line;
}

TEST(ReplayProgress, UnknownSizeSaysSoAndGivesSensorTimeScansPosesAndRate) {
  ReplayProgress p(std::nullopt);
  p.update(snapshot(0, 0, 0, 50.0, ""));
  const std::string line = p.line(snapshot(700, 30, 28, 56.0, "relocalizing"), 12.0);
  EXPECT_EQ(line, "700 done in 12.0 s, 6.0 s of data (0.5x real time), 30 scans replayed, 28 poses, "
                  "fuse-state relocalizing, input size unknown");
}

TEST(ReplayProgress, BeforeAnyScanIsAnsweredThereIsNoSensorTimeNorTracking) {
  ReplayProgress p(std::nullopt);
  EXPECT_EQ(p.line(snapshot(40, 0, 0, -1.0, ""), 6.0),
            "40 done in 6.0 s, 0 scans replayed, 0 poses, input size unknown");
}

TEST(ReplayProgress, AnEmptySizeIsUnknown) {
  ReplayProgress p(0);
  EXPECT_NE(p.line(snapshot(5, 1, 0, -1.0, ""), 6.0).find("input size unknown"), std::string::npos);
  EXPECT_NE(describe_replay_size(0).find("does not say"), std::string::npos);
}

TEST(ReplayProgress, TheSizeLineNamesWhatIsCounted) {
  EXPECT_NE(describe_replay_size(1234).find("1234 IMU samples and scans"), std::string::npos);
  EXPECT_NE(describe_replay_size(std::nullopt).find("without a percentage or time left"), std::string::npos);
}

}  // namespace
}  // namespace fuse::launch
