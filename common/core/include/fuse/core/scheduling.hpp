// Scheduler slice requests for latency-critical threads (Linux's EEVDF fair scheduler, 6.12 and
// later).
//
// EEVDF runs the eligible thread with the earliest virtual deadline, deadline = vruntime +
// slice / weight, and lets a running thread finish its slice before a waking one of equal
// standing takes the CPU. With the default slice (0.7 ms x (1 + log2 CPUs), 1.4 ms on two
// CPUs) a thread woken by a request on a machine whose CPUs are all busy waits up to that long.
// A thread that requests a short slice (sched_attr.sched_runtime of a SCHED_OTHER thread; the
// kernel clamps it to 0.1..100 ms) gets an earlier deadline and preempts the running thread when
// it wakes, at the price of being preempted sooner itself. Its weight, hence its CPU share, is
// unchanged, and no privilege is needed. Threads created afterwards inherit the request.
// Kernels without per-thread slices (CFS, before 6.12) accept and ignore it: a request reports
// whether the kernel holds it by reading it back.
#pragma once

#include <string>

namespace fuse {

/// Bounds of a slice request in microseconds (the kernel's clamp); 0 means the kernel default.
inline constexpr int kMinSchedulerSliceUs = 100;
inline constexpr int kMaxSchedulerSliceUs = 100000;

/// True for a value request_scheduler_slice accepts: 0, or within the bounds above.
inline constexpr bool valid_scheduler_slice(int slice_us) {
  return slice_us == 0 || (slice_us >= kMinSchedulerSliceUs && slice_us <= kMaxSchedulerSliceUs);
}

struct SliceRequest {
  bool applied = false;  ///< the kernel holds the requested slice for the thread
  std::string message;   ///< why not, when !applied
};

/// Requests a slice of `slice_us` (kMinSchedulerSliceUs..kMaxSchedulerSliceUs, or 0 for the
/// kernel default) for the calling thread, keeping its policy and nice value.
/// Throws std::invalid_argument for a value outside those bounds.
SliceRequest request_scheduler_slice(int slice_us);

/// The slice the kernel holds for thread `tid` (0: the calling thread) in microseconds, or 0
/// when the kernel reports none (no per-thread slices, or not a SCHED_OTHER thread).
int scheduler_slice_us(int tid = 0);

}  // namespace fuse
