// Progress (fuse/core/progress.hpp): the line says the share done and the time left when the
// total is known, the speed against real time when the work has a sensor time.
#include "fuse/core/progress.hpp"

#include <gtest/gtest.h>

namespace fuse {
namespace {

TEST(Progress, KnownTotalGivesPercentageAndTimeLeft) {
  Progress p("test", 200);
  p.update(0, 1000.0);  // the first sensor time
  const std::string line = p.line(50, 1030.0, 10.0, "tracking");
  EXPECT_NE(line.find("25 % (50 of 200)"), std::string::npos) << line;
  EXPECT_NE(line.find("30.0 s of data (3.0x real time)"), std::string::npos) << line;
  EXPECT_NE(line.find("about 30 s left"), std::string::npos) << line;
  EXPECT_NE(line.find(", tracking"), std::string::npos) << line;
}

TEST(Progress, UnknownTotalAndNoSensorTimeSayWhatIsKnown) {
  Progress p("test", std::nullopt);
  const std::string line = p.line(7, -1.0, 5.0, "");
  EXPECT_EQ(line, "7 done in 5.0 s");
}

}  // namespace
}  // namespace fuse
