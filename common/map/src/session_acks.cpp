#include "fuse/map/session_acks.hpp"

#include <algorithm>

namespace fuse {

SessionAcks::Session& SessionAcks::session(std::uint64_t id) {
  auto [it, created] = sessions_.try_emplace(id);
  if (created) it->second.last_active = ++clock_;
  return it->second;
}

void SessionAcks::advance(Session& s) {
  // Ranges are never adjacent, so one step reaches as far as the durable run goes.
  auto first = s.durable_above.begin();
  while (first != s.durable_above.end() && first->first <= s.acked + 1) {
    s.acked = std::max(s.acked, first->second);
    first = s.durable_above.erase(first);
  }
}

void SessionAcks::add_range(Session& s, std::uint64_t first, std::uint64_t last) {
  first = std::max(first, s.acked + 1);
  if (first > last) return;
  auto& ranges = s.durable_above;
  // Merge with every range it overlaps or touches.
  auto it = ranges.upper_bound(first);
  if (it != ranges.begin()) {
    const auto prev = std::prev(it);
    if (prev->second + 1 >= first) {
      first = prev->first;
      last = std::max(last, prev->second);
      it = ranges.erase(prev);
    }
  }
  while (it != ranges.end() && it->first <= last + 1) {
    last = std::max(last, it->second);
    it = ranges.erase(it);
  }
  ranges[first] = last;
  advance(s);
}

void SessionAcks::add_durable(std::uint64_t id, std::uint64_t sequence) { add_range(session(id), sequence, sequence); }

void SessionAcks::raise_floor(std::uint64_t id, std::uint64_t lowest_unacked) {
  if (lowest_unacked <= 1) return;
  Session& s = session(id);
  if (lowest_unacked - 1 <= s.acked) return;
  s.acked = lowest_unacked - 1;
  // Ranges now at or below the acknowledged sequence are part of it.
  auto it = s.durable_above.begin();
  while (it != s.durable_above.end() && it->second <= s.acked) it = s.durable_above.erase(it);
  if (it != s.durable_above.end() && it->first <= s.acked) {
    const std::uint64_t last = it->second;
    s.durable_above.erase(it);
    s.durable_above[s.acked + 1] = last;
  }
  advance(s);
}

void SessionAcks::touch(std::uint64_t id) { session(id).last_active = ++clock_; }

void SessionAcks::restore(std::uint64_t id, std::uint64_t acked,
                          const std::vector<std::pair<std::uint64_t, std::uint64_t>>& durable_ranges) {
  touch(id);
  raise_floor(id, acked + 1);
  Session& s = session(id);
  for (const auto& [first, last] : durable_ranges) add_range(s, first, last);
}

void SessionAcks::merge(const SessionAcks& other) {
  // Other's sessions in its activity order, oldest first, so that its newest become the newest.
  std::vector<std::uint64_t> order = other.by_activity();
  std::reverse(order.begin(), order.end());
  for (const std::uint64_t id : order) {
    const Session& o = other.sessions_.at(id);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges(o.durable_above.begin(), o.durable_above.end());
    restore(id, o.acked, ranges);
  }
}

std::uint64_t SessionAcks::acked(std::uint64_t id) const {
  const auto it = sessions_.find(id);
  return it == sessions_.end() ? 0 : it->second.acked;
}

bool SessionAcks::covered(std::uint64_t id, std::uint64_t sequence) const {
  const auto it = sessions_.find(id);
  if (it == sessions_.end()) return false;
  const Session& s = it->second;
  if (sequence <= s.acked) return true;
  auto next = s.durable_above.upper_bound(sequence);
  return next != s.durable_above.begin() && std::prev(next)->second >= sequence;
}

std::uint64_t SessionAcks::missing(std::uint64_t id) const {
  const auto it = sessions_.find(id);
  if (it == sessions_.end() || it->second.durable_above.empty()) return 0;
  const Session& s = it->second;
  std::uint64_t durable = 0;
  for (const auto& [first, last] : s.durable_above) durable += last - first + 1;
  return s.durable_above.rbegin()->second - s.acked - durable;
}

std::vector<std::uint64_t> SessionAcks::by_activity() const {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> order;  // (last_active, session)
  order.reserve(sessions_.size());
  for (const auto& [id, s] : sessions_) order.emplace_back(s.last_active, id);
  std::sort(order.rbegin(), order.rend());
  std::vector<std::uint64_t> ids;
  ids.reserve(order.size());
  for (const auto& [active, id] : order) ids.push_back(id);
  return ids;
}

std::vector<std::pair<std::uint64_t, std::uint64_t>> SessionAcks::recent(std::size_t n) const {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> out;
  for (const std::uint64_t id : by_activity()) {
    if (out.size() == n) break;
    out.emplace_back(id, sessions_.at(id).acked);
  }
  return out;
}

bool SessionAcks::operator==(const SessionAcks& other) const {
  if (sessions_.size() != other.sessions_.size()) return false;
  for (const auto& [id, s] : sessions_) {
    const auto it = other.sessions_.find(id);
    if (it == other.sessions_.end() || it->second.acked != s.acked || it->second.durable_above != s.durable_above) {
      return false;
    }
  }
  return true;
}

}  // namespace fuse
