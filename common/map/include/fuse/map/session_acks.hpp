// Which observations the map server acknowledges, per session (one fuse-update instance; its
// observations carry sequences 1, 2, ...). The rule (docs/architecture.md, "Map durability"):
//
//   the acknowledged sequence S of a session is the highest such that every sequence of that
//   session up to S is durable (journaled, or in the snapshot) or was given up by its sender.
//
// An observation durable above a hole (an earlier one is still pending or lost) is remembered
// and acknowledged once the hole is filled; the acknowledgement never jumps over the hole.
// Each observation says the lowest sequence its sender still holds unacknowledged: everything
// below it was acknowledged before (perhaps by a map server that has since lost it, or another
// map directory) or given up, so it raises the floor. That lets a map server that never saw the
// start of a session (a new map directory) acknowledge at all.
//
// The snapshot stores, per session, the acknowledged sequence and the durable ranges above it;
// the journal's records replay onto that (durable + floor), so a restart reconstructs exactly
// the acknowledgements it gave. Sessions also keep the order in which they were last active, so
// that map/status can list the recent ones, newest first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

namespace fuse {

class SessionAcks {
 public:
  struct Session {
    std::uint64_t acked = 0;
    /// Durable sequences above a hole: first -> last, disjoint, not adjacent, all above acked + 1.
    std::map<std::uint64_t, std::uint64_t> durable_above;
    std::uint64_t last_active = 0;  ///< larger: more recently active
  };

  /// The observation (session, sequence) is durable; acknowledged at once when it continues the
  /// acknowledged run (then with every durable one that the run now reaches).
  void add_durable(std::uint64_t session, std::uint64_t sequence);
  /// The sender holds nothing below lowest_unacked (0: unknown, no effect): acknowledges up to
  /// lowest_unacked - 1, then as far as the durable ranges continue.
  void raise_floor(std::uint64_t session, std::uint64_t lowest_unacked);
  /// Marks the session the most recently active one.
  void touch(std::uint64_t session);
  /// Restores a session as stored (acknowledged sequence and durable ranges); activity order is
  /// the order of the calls (the last one restored is the most recent).
  void restore(std::uint64_t session, std::uint64_t acked,
               const std::vector<std::pair<std::uint64_t, std::uint64_t>>& durable_ranges);
  /// Keeps, per session, the higher acknowledgement and every durable range of both.
  void merge(const SessionAcks& other);

  std::uint64_t acked(std::uint64_t session) const;
  /// Acknowledged, or durable above a hole: the observation must not be journaled again.
  bool covered(std::uint64_t session, std::uint64_t sequence) const;
  /// Sequences missing below the highest durable one (holes: pending, lost or never received).
  std::uint64_t missing(std::uint64_t session) const;

  const std::map<std::uint64_t, Session>& sessions() const { return sessions_; }
  /// (session, acknowledged sequence) of at most n sessions, most recently active first.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> recent(std::size_t n) const;
  /// Session ids, most recently active first (all of them).
  std::vector<std::uint64_t> by_activity() const;
  bool empty() const { return sessions_.empty(); }
  bool operator==(const SessionAcks& other) const;

 private:
  Session& session(std::uint64_t id);
  /// Adds [first, last] to the durable ranges (merging), then advances.
  static void add_range(Session& s, std::uint64_t first, std::uint64_t last);
  /// Moves acked over the durable range that starts right after it.
  static void advance(Session& s);

  std::map<std::uint64_t, Session> sessions_;
  std::uint64_t clock_ = 0;  ///< activity counter
};

}  // namespace fuse
