#include "fuse/service/instance_watch.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace fuse::service {

namespace {
/// Heartbeats each of two instances must have sent after the other's first one.
constexpr std::size_t kInterleavedBeats = 2;
}  // namespace

InstanceWatch::InstanceWatch(double window_s)
    : window_(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(window_s))) {}

void InstanceWatch::heard(const std::string& service, std::uint64_t instance, Clock::time_point t) {
  auto& instances = services_[service];
  auto [it, inserted] = instances.try_emplace(instance);
  if (inserted) it->second.first = t;
  it->second.recent.push_back(t);
  // Forget what fell out of the window, and instances no longer heard.
  for (auto i = instances.begin(); i != instances.end();) {
    auto& recent = i->second.recent;
    while (!recent.empty() && recent.front() < t - window_) recent.pop_front();
    i = recent.empty() ? instances.erase(i) : std::next(i);
  }
}

std::size_t InstanceWatch::beats_since(const Beats& a, Clock::time_point since, Clock::time_point now) const {
  return static_cast<std::size_t>(std::count_if(a.recent.begin(), a.recent.end(), [&](Clock::time_point t) {
    return t >= since && t >= now - window_;
  }));
}

std::vector<std::uint64_t> InstanceWatch::concurrent(const std::string& service, Clock::time_point now) const {
  std::vector<std::uint64_t> out;
  const auto s = services_.find(service);
  if (s == services_.end()) return out;
  for (const auto& [id_a, a] : s->second) {
    for (const auto& [id_b, b] : s->second) {
      if (id_a == id_b) continue;
      if (beats_since(a, b.first, now) >= kInterleavedBeats && beats_since(b, a.first, now) >= kInterleavedBeats) {
        out.push_back(id_a);
        break;
      }
    }
  }
  return out;
}

std::map<std::string, std::vector<std::uint64_t>> InstanceWatch::duplicates(Clock::time_point now) const {
  std::map<std::string, std::vector<std::uint64_t>> out;
  for (const auto& [service, instances] : services_) {
    auto ids = concurrent(service, now);
    if (!ids.empty()) out.emplace(service, std::move(ids));
  }
  return out;
}

std::string describe_duplicate(const std::string& service, const std::vector<std::uint64_t>& instances) {
  std::string ids;
  for (const std::uint64_t id : instances) ids += (ids.empty() ? "" : ", ") + fmt::format("{:016x}", id);
  return fmt::format("{} instances {} are alive at the same time: another system on this DDS domain uses the same "
                     "transport.system_name, or {} was started twice",
                     service, ids, service);
}

}  // namespace fuse::service
