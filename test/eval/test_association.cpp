// Timestamp association as evo's sync.associate_trajectories, and index association.
#include <gtest/gtest.h>

#include "fuse/eval/association.hpp"

namespace fuse::eval {
namespace {

Trajectory stamps(std::initializer_list<double> times) {
  Trajectory out;
  for (const double t : times) {
    StampedPose pose;
    pose.t = t;
    pose.p.x() = t;  // position encodes the stamp, so the match can be checked
    out.push_back(pose);
  }
  return out;
}

TEST(Association, MatchesNearestStampWithinMaxDifference) {
  const Trajectory ref = stamps({0.0, 0.1, 0.2, 0.3, 0.4, 0.5});
  const Trajectory est = stamps({0.004, 0.195, 0.33, 0.5});
  const AssociatedTrajectories a = associate_by_time(ref, est, 0.01);
  ASSERT_EQ(a.reference.size(), 3u);  // 0.33 is 0.03 s from its nearest reference stamp
  EXPECT_DOUBLE_EQ(a.reference[0].t, 0.0);
  EXPECT_DOUBLE_EQ(a.estimate[0].t, 0.004);
  EXPECT_DOUBLE_EQ(a.reference[1].t, 0.2);
  EXPECT_DOUBLE_EQ(a.reference[2].t, 0.5);
  EXPECT_EQ(associate_by_time(ref, est, 0.05).reference.size(), 4u);
}

TEST(Association, IteratesOverTheShorterTrajectory) {
  // Estimate longer than the reference: every reference pose picks its nearest estimate pose.
  const Trajectory ref = stamps({1.0, 2.0});
  const Trajectory est = stamps({0.99, 0.995, 1.002, 1.5, 1.999, 2.004});
  const AssociatedTrajectories a = associate_by_time(ref, est, 0.01);
  ASSERT_EQ(a.reference.size(), 2u);
  EXPECT_DOUBLE_EQ(a.estimate[0].t, 1.002);
  EXPECT_DOUBLE_EQ(a.estimate[1].t, 1.999);
  EXPECT_DOUBLE_EQ(a.reference[1].t, 2.0);
}

TEST(Association, TieTakesTheEarlierStampLikeArgmin) {
  const Trajectory ref = stamps({0.0, 0.25, 0.75, 1.0});
  const Trajectory est = stamps({0.5});
  const AssociatedTrajectories a = associate_by_time(ref, est, 0.3);
  ASSERT_EQ(a.reference.size(), 1u);
  EXPECT_DOUBLE_EQ(a.reference[0].t, 0.25);
}

TEST(Association, NoMatchOrBadInputThrows) {
  EXPECT_THROW(associate_by_time(stamps({0.0, 1.0}), stamps({0.5}), 0.01), std::runtime_error);
  EXPECT_THROW(associate_by_time(stamps({}), stamps({0.5}), 0.01), std::runtime_error);
  EXPECT_THROW(associate_by_time(stamps({0.0}), stamps({0.0}), -1.0), std::invalid_argument);
  EXPECT_THROW(associate_by_time(stamps({0.0, 2.0, 1.0}), stamps({0.0}), 0.01), std::invalid_argument);
  EXPECT_THROW(associate_by_time(stamps({0.0}), stamps({1.0, 1.0}), 0.01), std::invalid_argument);
}

TEST(Association, ByIndexNeedsEqualLengths) {
  EXPECT_EQ(associate_by_index(stamps({0, 1, 2}), stamps({5, 6, 7})).estimate[2].t, 7.0);
  try {
    associate_by_index(stamps({0, 1, 2}), stamps({0, 1}));
    FAIL() << "unequal lengths accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("reference has 3 poses, estimate has 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fuse::eval
