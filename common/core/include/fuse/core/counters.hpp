// Named counters of refused or flagged input (DESIGN "Standards": bad input is counted and
// reported, never silently dropped). The first occurrences of a reason and then every 100th are
// logged, so a flood of bad input stays readable.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <spdlog/logger.h>

namespace fuse {

class Counters {
 public:
  explicit Counters(std::shared_ptr<spdlog::logger> log) : log_(std::move(log)) {}
  /// Counts one occurrence of `reason` and logs `message` (rate-limited per reason).
  void count(const std::string& reason, const std::string& message) {
    const auto n = ++counts_[reason];
    if (n <= 5 || n % 100 == 0) log_->warn("{} (#{} '{}')", message, n, reason);
  }
  void add(const std::string& reason, std::uint64_t n = 1) { counts_[reason] += n; }
  const std::map<std::string, std::uint64_t>& map() const { return counts_; }
  std::uint64_t get(const std::string& reason) const {
    auto it = counts_.find(reason);
    return it == counts_.end() ? 0 : it->second;
  }

 private:
  std::shared_ptr<spdlog::logger> log_;
  std::map<std::string, std::uint64_t> counts_;
};

}  // namespace fuse
