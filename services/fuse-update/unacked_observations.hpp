// fuse-update's map observations that the map server has not acknowledged yet, kept to be
// re-sent in order until it does, within bounds (DESIGN §2, docs/architecture.md "Map
// durability"). The map server acknowledges per session the highest sequence up to which every
// observation is durable, so the ones held are always a suffix of what was sent, oldest first.
//
// Beyond update.max_unacked observations or update.max_unacked_bytes of points the oldest is
// given up: the caller counts and reports it, and every observation sent from then on carries
// lowest_unacked (the oldest one still held), which tells the map server that nothing below it
// will come again, so that it can acknowledge past the gap.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "fuse_msgs.h"

namespace fuse::service {

class UnackedObservations {
 public:
  using Clock = std::chrono::steady_clock;

  struct Limits {
    std::size_t max_count = 0;
    std::size_t max_bytes = 0;
    double resend_after_s = 0.0;
  };

  explicit UnackedObservations(const Limits& limits) : limits_(limits) {}

  /// What an observation with this sequence (the newest) carries as lowest_unacked.
  std::uint64_t lowest_unacked(std::uint64_t sequence) const;
  /// Keeps a sent observation; gives up the oldest beyond the bounds (never the one just
  /// added) and returns their sequences, oldest first.
  std::vector<std::uint64_t> add(fuse_msgs::MapObservation observation, Clock::time_point sent);
  /// The map server acknowledged every observation up to acked: drops them.
  void acknowledge(std::uint64_t acked);
  /// Copies of the observations due again (all of them when all), in order, with lowest_unacked
  /// brought up to date; they count as sent now. Due: sent longer than resend_after_s ago, the
  /// wait doubling with each re-send up to 2^kMaxBackoffDoublings times; `all` (a restarted map
  /// server) starts the doubling again.
  static constexpr unsigned kMaxBackoffDoublings = 4;
  std::vector<fuse_msgs::MapObservation> due(Clock::time_point now, bool all);

  std::size_t size() const { return held_.size(); }
  std::size_t bytes() const { return bytes_; }

  /// The acknowledged sequence of `session` in a map status: from its list of sessions, else its
  /// newest session's fields; nothing when the status does not name the session.
  static std::optional<std::uint64_t> acked_in(const fuse_msgs::MapStatus& status, std::uint64_t session);

 private:
  struct Held {
    fuse_msgs::MapObservation observation;
    Clock::time_point sent;
    std::size_t bytes = 0;  ///< of its points
    unsigned resends = 0;
  };

  Limits limits_;
  std::deque<Held> held_;
  std::size_t bytes_ = 0;
};

}  // namespace fuse::service
