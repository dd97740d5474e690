// Conversions between the wire types (fuse_msgs, generated) and the estimator's types. Only the
// services include this: the libraries never see a DDS type. Every conversion from the wire
// checks what arrived and says what was wrong (InvalidSample).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse_msgs.h"

namespace fuse::service {

/// A sample that decoded but whose contents are unusable (NaN, bad sizes, bad times).
class InvalidSample : public std::runtime_error {
 public:
  InvalidSample(std::string reason, const std::string& what) : std::runtime_error(what), reason_(std::move(reason)) {}
  const std::string& reason() const { return reason_; }  ///< counter name

 private:
  std::string reason_;
};

fuse_msgs::ImuSample to_msg(const ImuSample& imu, const std::string& frame);
ImuSample from_msg(const fuse_msgs::ImuSample& msg);  ///< throws InvalidSample

fuse_msgs::LidarScan to_msg(const LidarScan& scan, const std::string& frame);
LidarScan from_msg(const fuse_msgs::LidarScan& msg);  ///< throws InvalidSample
/// The checks from_msg makes on a scan (times, span, point time offsets); throws InvalidSample.
void check_scan(const LidarScan& scan);
/// A scan straight to its wire bytes (a fuse_msgs::LidarScan sample) through the direct codec
/// (io::encode_scan): the same bytes as to_msg + serialise, at a tenth of the cost. Readers
/// decode with io::decode_scan, then check_scan.
std::vector<std::uint8_t> scan_to_wire(const LidarScan& scan, const std::string& frame);

/// The posterior at a scan end, with the full error-state covariance.
struct Posterior {
  double t = 0.0;
  std::uint64_t scan_sequence = 0;
  NavState x;
  StateCovariance P = StateCovariance::Zero();
};
/// The world frame a posterior is in against a saved map (fuse_msgs::MapFrame), and how many
/// times fuse-state's history changed frame before it (docs/architecture.md, "Starting anywhere
/// in a saved map").
struct WorldFrame {
  fuse_msgs::MapFrame state = fuse_msgs::MAP_FRAME_UNDECIDED;
  std::uint32_t epoch = 0;
  /// Searching or confirming: the world frame is not (yet) the saved map's.
  bool relocalizing() const {
    return state == fuse_msgs::MAP_FRAME_SEARCHING || state == fuse_msgs::MAP_FRAME_CONFIRMING;
  }
};
const char* to_string(fuse_msgs::MapFrame state);
bool valid(fuse_msgs::MapFrame state);  ///< one of the states the IDL names
/// The frame a correction says it is in (throws InvalidSample for an unknown state).
WorldFrame frame_of(const fuse_msgs::Correction& msg);
/// Its frame_change, T_new_old (throws InvalidSample when not a rigid transform).
Eigen::Isometry3d frame_change_of(const fuse_msgs::Correction& msg);
fuse_msgs::Correction to_msg(const Posterior& posterior);
Posterior from_msg(const fuse_msgs::Correction& msg);  ///< throws InvalidSample

fuse_msgs::HistoryEntry to_msg(const StateHistory::Entry& e);
StateHistory::Entry from_msg(const fuse_msgs::HistoryEntry& msg);  ///< P zero; throws InvalidSample

/// A state query as the planners' estimate (pose covariance: position and rotation blocks).
fuse_msgs::StateEstimate to_estimate(const StateQuery& q, std::uint64_t sequence);

fuse_msgs::Pose to_pose(const Eigen::Vector3d& p, const Eigen::Matrix3d& R);
Eigen::Isometry3d from_pose(const fuse_msgs::Pose& pose);  ///< throws InvalidSample

}  // namespace fuse::service
