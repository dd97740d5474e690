// Scheduler slice requests (fuse/core/scheduling.hpp): bounds, the kernel holding the request,
// inheritance by threads created afterwards, and the return to the default. Each test runs its
// requests on a thread of its own so that the test runner's thread keeps its attributes.
#include "fuse/core/scheduling.hpp"

#include <gtest/gtest.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <stdexcept>
#include <thread>

namespace {

using fuse::request_scheduler_slice;
using fuse::scheduler_slice_us;

int this_tid() { return static_cast<int>(syscall(SYS_gettid)); }

TEST(SchedulerSlice, RefusesValuesOutsideTheKernelsBounds) {
  for (int bad : {-1, 1, 99, 100001, 1000000}) {
    EXPECT_THROW(request_scheduler_slice(bad), std::invalid_argument) << bad;
  }
}

TEST(SchedulerSlice, IsHeldInheritedByNewThreadsAndReset) {
  std::thread([] {
    const int before = scheduler_slice_us();
    const fuse::SliceRequest r = request_scheduler_slice(200);
    if (!r.applied) GTEST_SKIP() << "no per-thread slices on this kernel: " << r.message;
    ASSERT_GT(before, 0) << "a kernel that keeps slices reports the default one";
    EXPECT_NE(before, 200) << "the default slice must differ from the request for this test to mean anything";
    EXPECT_EQ(scheduler_slice_us(), 200);
    EXPECT_EQ(scheduler_slice_us(this_tid()), 200) << "by thread id as by 0";

    int child = 0;
    std::thread([&child] { child = scheduler_slice_us(); }).join();
    EXPECT_EQ(child, 200) << "a thread created after the request inherits it";

    EXPECT_TRUE(request_scheduler_slice(0).applied);
    EXPECT_EQ(scheduler_slice_us(), before) << "0 returns to the kernel's default slice";
    std::thread([&child] { child = scheduler_slice_us(); }).join();
    EXPECT_EQ(child, before);
  }).join();
}

TEST(SchedulerSlice, DoesNotTouchOtherThreads) {
  const int mine = scheduler_slice_us();
  std::thread([] { request_scheduler_slice(300); }).join();
  EXPECT_EQ(scheduler_slice_us(), mine);
}

}  // namespace
