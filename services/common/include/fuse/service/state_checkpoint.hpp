// fuse-state's own copy of its newest corrected posterior (state.checkpoint_file), so that it
// recovers after a restart even when no other process still holds a correction (fuse-update
// restarted with it, or is gone). DESIGN §2: "the estimate comes back ... from a held or
// checkpointed posterior".
//
// File: "FUSESCKP" | u32 format version | u32 length | u32 CRC-32 of the payload | payload, the
// payload being the posterior as the wire's Correction with its world frame (XCDR1, little-endian: one encoding for
// what travels and what is kept) followed by the 36 little-endian doubles of the map frame's
// accumulated uncertainty (row-major 6x6, see ScanReport::map_drift). Written to FILE.tmp and renamed over FILE (a reader sees the old
// or the new checkpoint, never a torn one); not fsync'd: it guards against the process dying, and
// after a power cut the vehicle starts again from rest. Writes run on their own thread, newest
// wins, so a slow disk never delays a correction. A checkpoint that is missing, damaged or of
// another version is reported and ignored, never trusted.
#pragma once

#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "fuse/service/convert.hpp"

namespace fuse::service {

using PoseCovariance = Eigen::Matrix<double, 6, 6>;

struct Checkpoint {
  Posterior posterior;
  PoseCovariance map_drift = PoseCovariance::Zero();  ///< accumulated up to the posterior
  WorldFrame frame;                                   ///< the frame the posterior is in
};

/// Reads a checkpoint; nullopt with `why` set when there is none or it cannot be trusted.
std::optional<Checkpoint> read_checkpoint(const std::filesystem::path& file, std::string& why);
/// Writes a checkpoint atomically (temp file + rename); throws std::runtime_error on I/O failure.
void write_checkpoint(const std::filesystem::path& file, const Checkpoint& checkpoint);

class CheckpointWriter {
 public:
  /// period_s: at most one write per period (the newest posterior offered wins).
  CheckpointWriter(std::filesystem::path file, double period_s);
  ~CheckpointWriter();
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;

  void offer(const Checkpoint& checkpoint);
  std::uint64_t written() const;
  std::uint64_t failures() const;
  std::string last_error() const;

 private:
  void run();

  std::filesystem::path file_;
  std::chrono::duration<double> period_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<Checkpoint> pending_;
  bool stop_ = false;
  std::uint64_t written_ = 0, failures_ = 0;
  std::string last_error_;
  std::thread thread_;
};

}  // namespace fuse::service
