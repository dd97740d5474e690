#include "unacked_observations.hpp"

#include <algorithm>

namespace fuse::service {

std::uint64_t UnackedObservations::lowest_unacked(std::uint64_t sequence) const {
  return held_.empty() ? sequence : held_.front().observation.sequence_number();
}

std::vector<std::uint64_t> UnackedObservations::add(fuse_msgs::MapObservation observation, Clock::time_point sent) {
  const std::size_t bytes = observation.points().size() * sizeof(fuse_msgs::Point3f);
  held_.push_back({std::move(observation), sent, bytes});
  bytes_ += bytes;
  std::vector<std::uint64_t> given_up;
  while (held_.size() > 1 && (held_.size() > limits_.max_count || bytes_ > limits_.max_bytes)) {
    given_up.push_back(held_.front().observation.sequence_number());
    bytes_ -= held_.front().bytes;
    held_.pop_front();
  }
  return given_up;
}

void UnackedObservations::acknowledge(std::uint64_t acked) {
  while (!held_.empty() && held_.front().observation.sequence_number() <= acked) {
    bytes_ -= held_.front().bytes;
    held_.pop_front();
  }
}

std::vector<fuse_msgs::MapObservation> UnackedObservations::due(Clock::time_point now, bool all) {
  std::vector<fuse_msgs::MapObservation> out;
  if (held_.empty()) return out;
  const std::uint64_t lowest = held_.front().observation.sequence_number();
  for (Held& h : held_) {
    // Backoff: resend_after_s, then twice as long after each re-send, up to kMaxBackoff times
    // (a map server that is up but cannot store, e.g. a full disk, is not flooded with copies).
    const double wait = limits_.resend_after_s * static_cast<double>(1u << std::min(h.resends, kMaxBackoffDoublings));
    if (!all && now - h.sent < std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(wait))) continue;
    h.observation.lowest_unacked(lowest);  // what the map server may settle has moved on since
    h.sent = now;
    h.resends = all ? 0 : h.resends + 1;  // all: a new map server instance, first try again
    out.push_back(h.observation);
  }
  return out;
}

std::optional<std::uint64_t> UnackedObservations::acked_in(const fuse_msgs::MapStatus& status, std::uint64_t session) {
  for (const fuse_msgs::SessionAck& a : status.sessions()) {
    if (a.session() == session) return a.acked_sequence();
  }
  if (status.session() == session) return status.acked_sequence();
  return std::nullopt;
}

}  // namespace fuse::service
