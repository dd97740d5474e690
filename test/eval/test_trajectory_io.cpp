// TUM / KITTI readers and writer: valid files, and every kind of malformed line.
#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>

#include "fuse/eval/trajectory.hpp"
#include "test_helpers.hpp"

namespace fuse::eval {
namespace {

using test::TempFile;

/// Expects read to throw std::runtime_error whose message names `file:line` and contains `what`.
template <typename Read>
void expect_error(Read read, const std::string& where, const std::string& what) {
  try {
    read();
    FAIL() << "no error; expected one mentioning '" << what << "'";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(where), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << msg;
  }
}

void expect_tum_error(const std::string& content, int line, const std::string& what) {
  const TempFile file(content);
  expect_error([&] { read_tum(file.path()); }, file.path() + ":" + std::to_string(line) + ":", what);
}

constexpr const char* kIdentityKitti = "1 0 0 0 0 1 0 0 0 0 1 0\n";

TEST(TrajectoryIo, ReadsTumSkippingCommentsAndBlankLines) {
  const TempFile file("# t x y z qx qy qz qw\n\n0.5 1 2 3 0 0 0 1\n  # indented comment\n0.6 1.5 2 3 0 0 0.7071067811865476 0.7071067811865476\n");
  const Trajectory t = read_tum(file.path());
  ASSERT_EQ(t.size(), 2u);
  EXPECT_DOUBLE_EQ(t[0].t, 0.5);
  EXPECT_TRUE(t[0].p.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_NEAR(t[1].q.w(), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(t[1].q.z(), std::sqrt(0.5), 1e-12);
}

TEST(TrajectoryIo, NormalisesNearlyUnitQuaternion) {
  const TempFile file("0 0 0 0 0 0 0 1.001\n");
  const Trajectory t = read_tum(file.path());
  EXPECT_NEAR(t[0].q.norm(), 1.0, 1e-15);
}

TEST(TrajectoryIo, RejectsMalformedTumLines) {
  expect_tum_error("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n", 2, "expected 8 columns, found 7");
  expect_tum_error("0 0 0 0 0 0 0 1 5\n", 1, "expected 8 columns, found 9");
  expect_tum_error("0 0 abc 0 0 0 0 1\n", 1, "'abc' is not a number");
  expect_tum_error("0 0 1.5x 0 0 0 0 1\n", 1, "'1.5x' is not a number");
  expect_tum_error("0 nan 0 0 0 0 0 1\n", 1, "not a finite number");
  expect_tum_error("0 0 inf 0 0 0 0 1\n", 1, "not a finite number");
  expect_tum_error("0 0 0 1e999 0 0 0 1\n", 1, "not a finite number");
  expect_tum_error("0 0 0 0 0 0 0 2\n", 1, "quaternion is not unit");
  expect_tum_error("0 0 0 0 0 0 0 0\n", 1, "quaternion is not unit");
  expect_tum_error("1 0 0 0 0 0 0 1\n# c\n0.5 0 0 0 0 0 0 1\n", 3, "before the previous one");
}

TEST(TrajectoryIo, RepeatedTimestampKeepsFirstPose) {
  const TempFile file("1 0 0 0 0 0 0 1\n1 5 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
  const Trajectory t = read_tum(file.path());
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].p.x(), 0.0);
  EXPECT_EQ(t[1].t, 2.0);
}

TEST(TrajectoryIo, RejectsMissingAndEmptyFiles) {
  expect_error([] { read_tum("/nonexistent/fuse_eval_missing.txt"); }, "fuse_eval_missing.txt", "cannot open");
  const TempFile empty("# only a comment\n");
  expect_error([&] { read_tum(empty.path()); }, empty.path(), "contains no poses");
  expect_error([&] { read_kitti(empty.path()); }, empty.path(), "contains no poses");
}

TEST(TrajectoryIo, ReadsKittiWithIndexOrTimesFile) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  std::ostringstream line;
  line.precision(17);
  line << R(0, 0) << ' ' << R(0, 1) << ' ' << R(0, 2) << " 4 " << R(1, 0) << ' ' << R(1, 1) << ' ' << R(1, 2)
       << " 5 " << R(2, 0) << ' ' << R(2, 1) << ' ' << R(2, 2) << " 6\n";
  const TempFile poses(std::string(kIdentityKitti) + line.str());
  const Trajectory t = read_kitti(poses.path());
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t, 0.0);
  EXPECT_EQ(t[1].t, 1.0);
  EXPECT_TRUE(t[1].p.isApprox(Eigen::Vector3d(4, 5, 6)));
  EXPECT_TRUE(t[1].q.toRotationMatrix().isApprox(R, 1e-12));

  const TempFile times("0.0\n0.1036\n");
  EXPECT_DOUBLE_EQ(read_kitti(poses.path(), times.path())[1].t, 0.1036);
  const TempFile short_times("0.0\n");
  expect_error([&] { read_kitti(poses.path(), short_times.path()); }, short_times.path(), "has 1 timestamps");
  const TempFile bad_times("0.0\n0.0\n");
  expect_error([&] { read_kitti(poses.path(), bad_times.path()); }, bad_times.path() + ":2:", "not increasing");
}

TEST(TrajectoryIo, RejectsMalformedKittiLines) {
  const TempFile columns(std::string(kIdentityKitti) + "1 0 0 0 0 1 0 0 0 0 1\n");
  expect_error([&] { read_kitti(columns.path()); }, columns.path() + ":2:", "expected 12 columns, found 11");
  const TempFile scaled("2 0 0 0 0 2 0 0 0 0 2 0\n");
  expect_error([&] { read_kitti(scaled.path()); }, scaled.path() + ":1:", "not a rotation");
  const TempFile reflection("-1 0 0 0 0 1 0 0 0 0 1 0\n");
  expect_error([&] { read_kitti(reflection.path()); }, reflection.path() + ":1:", "not a rotation");
  const TempFile nan_value("1 0 0 nan 0 1 0 0 0 0 1 0\n");
  expect_error([&] { read_kitti(nan_value.path()); }, nan_value.path() + ":1:", "not a finite number");
}

TEST(TrajectoryIo, WriteTumRoundTrips) {
  Trajectory in = test::circle(3.0, 17);
  in[3].t = 1311868164.363181;  // a TUM RGB-D-sized stamp must survive with 9 decimals
  for (std::size_t i = 4; i < in.size(); ++i) in[i].t = in[3].t + 0.1 * static_cast<double>(i);
  const TempFile file("");
  write_tum(file.path(), in);
  const Trajectory out = read_tum(file.path());
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_NEAR(out[i].t, in[i].t, 1e-6);
    EXPECT_NEAR((out[i].p - in[i].p).norm(), 0.0, 1e-8);
    EXPECT_NEAR(out[i].q.angularDistance(in[i].q), 0.0, 1e-8);
  }
}

TEST(TrajectoryIo, WriteTumRejectsNonFinitePoseAndBadPath) {
  Trajectory in = test::circle(1.0, 3);
  in[1].p.x() = std::nan("");
  const TempFile file("");
  EXPECT_THROW(write_tum(file.path(), in), std::runtime_error);
  EXPECT_THROW(write_tum("/nonexistent_dir/x.txt", test::circle(1.0, 3)), std::runtime_error);
}

TEST(TrajectoryIo, ParsesFormatNames) {
  EXPECT_EQ(parse_trajectory_format("tum"), TrajectoryFormat::kTum);
  EXPECT_EQ(parse_trajectory_format("kitti"), TrajectoryFormat::kKitti);
  EXPECT_THROW(parse_trajectory_format("euroc"), std::invalid_argument);
}

}  // namespace
}  // namespace fuse::eval
