#include "fuse/core/scheduling.hpp"

#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace fuse {

namespace {

/// struct sched_attr of sched_setattr(2), the first version (48 bytes), which is all we use.
struct SchedAttr {
  std::uint32_t size = sizeof(SchedAttr);
  std::uint32_t sched_policy = 0;
  std::uint64_t sched_flags = 0;
  std::int32_t sched_nice = 0;
  std::uint32_t sched_priority = 0;
  std::uint64_t sched_runtime = 0;  ///< ns; for SCHED_OTHER/BATCH the requested slice (EEVDF)
  std::uint64_t sched_deadline = 0;
  std::uint64_t sched_period = 0;
};
static_assert(sizeof(SchedAttr) == 48, "sched_attr version 0 is 48 bytes");

bool get_attr(int tid, SchedAttr& attr) {
  return syscall(SYS_sched_getattr, tid, &attr, static_cast<unsigned>(sizeof(attr)), 0u) == 0;
}

}  // namespace

int scheduler_slice_us(int tid) {
  SchedAttr attr;
  if (!get_attr(tid, attr)) return 0;
  if (attr.sched_policy != SCHED_OTHER && attr.sched_policy != SCHED_BATCH) return 0;
  return static_cast<int>(attr.sched_runtime / 1000);
}

SliceRequest request_scheduler_slice(int slice_us) {
  if (!valid_scheduler_slice(slice_us)) {
    throw std::invalid_argument("scheduler slice " + std::to_string(slice_us) + " us is outside " +
                                std::to_string(kMinSchedulerSliceUs) + ".." + std::to_string(kMaxSchedulerSliceUs) +
                                " (or 0 for the kernel default)");
  }
  SliceRequest result;
  SchedAttr attr;
  if (!get_attr(0, attr)) {
    result.message = std::string("sched_getattr failed: ") + std::strerror(errno);
    return result;
  }
  if (attr.sched_policy != SCHED_OTHER && attr.sched_policy != SCHED_BATCH) {
    result.message = "the thread runs under a real-time or idle policy, which has no fair-scheduler slice";
    return result;
  }
  // Keep policy and nice: only the slice changes. 0 returns to the kernel's default slice.
  attr.size = sizeof(attr);
  attr.sched_flags = 0;
  attr.sched_runtime = static_cast<std::uint64_t>(slice_us) * 1000u;
  attr.sched_deadline = 0;
  attr.sched_period = 0;
  if (syscall(SYS_sched_setattr, 0, &attr, 0u) != 0) {
    result.message = std::string("sched_setattr failed: ") + std::strerror(errno);
    return result;
  }
  if (slice_us == 0) {
    result.applied = true;
    return result;
  }
  // A kernel without per-thread slices accepts the call and reports no slice back.
  if (scheduler_slice_us(0) != slice_us) {
    result.message = "the kernel does not keep per-thread slices (EEVDF custom slices need Linux 6.12 or later)";
    return result;
  }
  result.applied = true;
  return result;
}

}  // namespace fuse
