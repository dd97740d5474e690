// The planner client's ABI policy (tools/fuse-query/CMakeLists.txt): the SONAME's number is bumped
// whenever a type of client.hpp changes its layout. This test holds the layout recorded for the
// number in force; when the header changes, it fails until FUSE_QUERY_SOVERSION is bumped and the
// new layout recorded here (with a line in debian/changelog: the library package is renamed).
#include <gtest/gtest.h>

#include <cstddef>
#include <string>

#include "fuse/query/client.hpp"

namespace fuse::query {
namespace {

struct Layout {
  std::size_t estimate_size, estimate_t, position, orientation, velocity, pose_covariance, velocity_covariance, status;
  std::size_t angular_velocity, host_clock, frame_id, child_frame_id;  // from SONAME 2 on (0 before)
  std::size_t result_size, result_message, result_estimate;
  std::size_t options_size;
  int last_error, last_status;  // the values of Error::not_tracking and Status::lost (the last ones)
};

// One entry per SONAME; only the current one is compared.
Layout recorded(int soversion) {
  switch (soversion) {
    case 1:
      return {456, 0, 8, 32, 64, 88, 376, 448, 0, 0, 0, 0, 496, 8, 40, 104, 6, 6};
    case 2:  // + angular_velocity, host_clock, frame names; at(t, Clock), subscribe(), newest()
      return {568, 0, 8, 32, 64, 112, 400, 472, 88, 480, 504, 536, 608, 8, 40, 104, 6, 6};
    case 3:  // ClientOptions + system_name, the DDS Security identity (security_*), interfaces, peers
      return {568, 0, 8, 32, 64, 112, 400, 472, 88, 480, 504, 536, 608, 8, 40, 288, 6, 6};
    default:
      ADD_FAILURE() << "no layout recorded for SONAME " << soversion << ": add it to query_abi_test.cpp";
      return {};
  }
}

TEST(QueryAbi, TheHeaderHasTheLayoutOfItsSoname) {
  const Layout want = recorded(FUSE_QUERY_SOVERSION_BUILT);
  const Layout have{sizeof(Estimate),
                    offsetof(Estimate, t),
                    offsetof(Estimate, position),
                    offsetof(Estimate, orientation_xyzw),
                    offsetof(Estimate, velocity),
                    offsetof(Estimate, pose_covariance),
                    offsetof(Estimate, velocity_covariance),
                    offsetof(Estimate, status),
                    offsetof(Estimate, angular_velocity),
                    offsetof(Estimate, host_clock),
                    offsetof(Estimate, frame_id),
                    offsetof(Estimate, child_frame_id),
                    sizeof(Result),
                    offsetof(Result, message),
                    offsetof(Result, estimate),
                    sizeof(ClientOptions),
                    static_cast<int>(Error::not_tracking),
                    static_cast<int>(Status::lost)};
  const std::string bump = " changed: bump FUSE_QUERY_SOVERSION (tools/fuse-query/CMakeLists.txt) and record the new layout";
  EXPECT_EQ(have.estimate_size, want.estimate_size) << "sizeof(Estimate)" << bump;
  EXPECT_EQ(have.estimate_t, want.estimate_t) << "Estimate::t" << bump;
  EXPECT_EQ(have.position, want.position) << "Estimate::position" << bump;
  EXPECT_EQ(have.orientation, want.orientation) << "Estimate::orientation_xyzw" << bump;
  EXPECT_EQ(have.velocity, want.velocity) << "Estimate::velocity" << bump;
  EXPECT_EQ(have.pose_covariance, want.pose_covariance) << "Estimate::pose_covariance" << bump;
  EXPECT_EQ(have.velocity_covariance, want.velocity_covariance) << "Estimate::velocity_covariance" << bump;
  EXPECT_EQ(have.status, want.status) << "Estimate::status" << bump;
  EXPECT_EQ(have.angular_velocity, want.angular_velocity) << "Estimate::angular_velocity" << bump;
  EXPECT_EQ(have.host_clock, want.host_clock) << "Estimate::host_clock" << bump;
  EXPECT_EQ(have.frame_id, want.frame_id) << "Estimate::frame_id" << bump;
  EXPECT_EQ(have.child_frame_id, want.child_frame_id) << "Estimate::child_frame_id" << bump;
  EXPECT_EQ(have.result_size, want.result_size) << "sizeof(Result)" << bump;
  EXPECT_EQ(have.result_message, want.result_message) << "Result::message" << bump;
  EXPECT_EQ(have.result_estimate, want.result_estimate) << "Result::estimate" << bump;
  EXPECT_EQ(have.options_size, want.options_size) << "sizeof(ClientOptions)" << bump;
  EXPECT_EQ(have.last_error, want.last_error) << "enum Error" << bump;
  EXPECT_EQ(have.last_status, want.last_status) << "enum Status" << bump;
}

}  // namespace
}  // namespace fuse::query
