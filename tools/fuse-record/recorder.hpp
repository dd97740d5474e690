// fuse-record's core (issue 5 item 2): one raw DDS reader per chosen topic hands each sample's
// bytes to a bounded queue (SampleQueue; a sample that does not fit is counted as dropped); one
// writer thread checks each sample against its type and writes it to the rotating MCAP output.
// Log times: imu and lidar/scan carry their own time (IMU t, scan end), as fuse-sim writes them,
// so fuse-ingest replays the recording in the order the data was taken; every other topic is
// stamped with the newest such sensor time seen when it was written (one clock per file).
// With a Foxglove view, the writer thread also turns the recorded odometry, corrected states,
// deskewed scans, map chunks and health into the Foxglove channels fuse-viz serves
// (fuse/service/foxglove_view.hpp), written beside them at the same log times, so that the
// recording draws in Foxglove and Lichtblick with no setup.
#pragma once

#include <atomic>
#include <optional>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fuse/service/foxglove_view.hpp"
#include "fuse/transport/transport.hpp"
#include "rotating_writer.hpp"
#include "sample_queue.hpp"
#include "topic_catalog.hpp"

namespace fuse::record {

struct TopicStats {
  std::string topic;
  std::uint64_t received = 0;   ///< samples delivered by DDS
  std::uint64_t dropped = 0;    ///< refused by the full queue
  std::uint64_t malformed = 0;  ///< failed the type check (not written)
  std::uint64_t written = 0;
  std::uint64_t bytes = 0;      ///< bytes written
};

/// What the Foxglove channels need: frame names and periods (the viz section), the extrinsic.
struct FoxgloveRecording {
  service::VizConfig viz;
  Eigen::Isometry3d T_imu_lidar = Eigen::Isometry3d::Identity();
};

class Recorder {
 public:
  /// Subscribes to `topics` and starts the writer thread. Throws std::runtime_error when the
  /// output cannot be created or a reader cannot.
  /// With `foxglove`, output.extra_channels must be FoxgloveView::channels().
  Recorder(transport::Participant& participant, std::vector<const TopicType*> topics, const RotationOptions& output,
           std::size_t queue_bytes, const std::optional<FoxgloveRecording>& foxglove = std::nullopt);
  ~Recorder();
  /// Stops the readers, writes what is queued, closes the last file. Idempotent.
  void stop();
  /// True once the writer thread hit an error it cannot go on from (logged; see error()).
  bool failed() const { return failed_; }
  std::string error() const;
  std::vector<TopicStats> stats() const;
  std::vector<FileSummary> files() const;
  std::size_t queue_peak_bytes() const { return queue_.peak_bytes(); }
  /// Samples recorded whose Foxglove form could not be made (not drawn; logged rate-limited).
  std::uint64_t foxglove_skipped() const { return foxglove_skipped_; }

 private:
  struct Counters {
    std::atomic<std::uint64_t> received{0}, dropped{0}, malformed{0}, written{0}, bytes{0};
  };
  void on_sample(std::size_t topic, const std::uint8_t* data, std::size_t size);
  void run();
  void write(const QueuedSample& s);
  /// Writes a checked sample at log_time (ns) and counts it.
  void put(const QueuedSample& s, std::uint64_t log_time);
  /// The sample's Foxglove messages, at its log time; the map and trajectory when due.
  void draw(const QueuedSample& s, std::uint64_t log_time);
  /// The map and the trajectory, when changed and (unless `final`) due.
  void draw_periodic(std::uint64_t log_time, bool final);
  void write_foxglove(const service::FoxgloveMessage& m, std::uint64_t log_time);

  std::vector<const TopicType*> topics_;
  std::vector<std::unique_ptr<Counters>> counters_;
  SampleQueue queue_;
  RotatingWriter writer_;
  /// The log time base is the sensor clock. The newest sensor-stamped sample: its time (ns) and
  /// when it was received; a sample without a sensor time is logged at that time plus the host
  /// time elapsed since (writer thread only).
  std::optional<std::pair<std::uint64_t, std::chrono::steady_clock::time_point>> anchor_;
  /// Samples without a sensor time received before the first with one: logged, when it comes,
  /// at its time less how much earlier they were received (writer thread only).
  std::vector<QueuedSample> before_anchor_;
  bool host_clock_warned_ = false;  ///< said once that samples went to the host clock
  std::atomic<bool> stopping_{false}, failed_{false};
  mutable std::mutex mutex_;  ///< guards error_ and writer_'s file list
  std::string error_;
  std::optional<service::FoxgloveView> view_;  ///< writer thread only
  std::optional<FoxgloveRecording> foxglove_;
  bool static_written_ = false;
  std::uint64_t next_map_ns_ = 0, next_trajectory_ns_ = 0, last_log_ns_ = 0;
  std::atomic<std::uint64_t> foxglove_skipped_{0};
  std::vector<std::unique_ptr<transport::RawReader>> readers_;
  std::thread thread_;
  bool stopped_ = false;
};

}  // namespace fuse::record
