// CpuLatencyRequest (cpu_latency.hpp): the bound goes to the device as a binary 32-bit integer
// and stays in force while the request lives; bad bounds throw, a missing device is reported.
#include "fuse/core/cpu_latency.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace fuse {
namespace {

namespace fs = std::filesystem;

TEST(CpuLatency, RefusesBoundsOutsideTheRange) {
  EXPECT_THROW(CpuLatencyRequest(-1), std::invalid_argument);
  EXPECT_THROW(CpuLatencyRequest(kMaxCpuLatencyUs + 1), std::invalid_argument);
}

TEST(CpuLatency, AMissingDeviceIsReportedNotApplied) {
  const CpuLatencyRequest r(0, "/nonexistent/cpu_dma_latency");
  EXPECT_FALSE(r.applied());
  EXPECT_NE(r.message().find("/nonexistent/cpu_dma_latency"), std::string::npos) << r.message();
  EXPECT_EQ(cpu_latency_in_force_us("/nonexistent/cpu_dma_latency"), -1);
}

// A regular file stands in for the device: what is written is the bound as an int32.
TEST(CpuLatency, WritesTheBoundAsABinaryInt32) {
  const fs::path file = fs::temp_directory_path() / ("fuse-cpu-latency-" + std::to_string(::getpid()));
  std::ofstream(file).close();
  {
    CpuLatencyRequest r(1234, file.string());
    ASSERT_TRUE(r.applied()) << r.message();
    CpuLatencyRequest moved = std::move(r);
    EXPECT_TRUE(moved.applied());
    EXPECT_FALSE(r.applied());  // NOLINT(bugprone-use-after-move): the moved-from request holds nothing
  }
  EXPECT_EQ(fs::file_size(file), sizeof(std::int32_t));
  EXPECT_EQ(cpu_latency_in_force_us(file.string()), 1234);
  fs::remove(file);
}

// The kernel's PM QoS device: while the request lives, the bound in force is at most ours (other
// holders may hold a smaller one). Writing the device needs root or a udev rule (deploy/).
TEST(CpuLatency, TheKernelHoldsTheBoundWhileTheRequestLives) {
  if (::access(kCpuLatencyDevice, W_OK) != 0) {
    GTEST_SKIP() << kCpuLatencyDevice << " is not writable here (needs root or the deploy's udev rule)";
  }
  const CpuLatencyRequest r(7);
  ASSERT_TRUE(r.applied()) << r.message();
  const int in_force = cpu_latency_in_force_us();
  EXPECT_GE(in_force, 0);
  EXPECT_LE(in_force, 7);
}

}  // namespace
}  // namespace fuse
