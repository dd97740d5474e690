// Named counters of refused or flagged input (DESIGN "Standards": bad input is counted and
// reported, never silently dropped). Logging is rate-limited per reason: the first
// kFirstMessages occurrences are logged, then at most one message per kInterval, which says how
// many occurrences it stands for, so a flood of bad input (a full disk, a stuck clock) stays
// readable and still tells how much happened.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <spdlog/logger.h>

namespace fuse {

/// Rate limit of one repeated message: allow() says whether occurrence n (1, 2, ...) is logged.
class LogRateLimit {
 public:
  static constexpr std::uint64_t kFirstMessages = 5;
  static constexpr std::chrono::milliseconds kInterval{5000};

  explicit LogRateLimit(std::chrono::milliseconds interval = kInterval) : interval_(interval) {}

  /// True when this occurrence is to be logged; `suppressed` is then the number of occurrences
  /// since the previous logged one that were not.
  bool allow(std::uint64_t& suppressed) {
    using Clock = std::chrono::steady_clock;
    const auto now = Clock::now();
    ++seen_;
    if (seen_ <= kFirstMessages || now - last_ >= interval_) {
      suppressed = seen_ - logged_at_ - 1;
      logged_at_ = seen_;
      last_ = now;
      return true;
    }
    return false;
  }

 private:
  std::chrono::milliseconds interval_;
  std::uint64_t seen_ = 0;
  std::uint64_t logged_at_ = 0;
  std::chrono::steady_clock::time_point last_{};
};

class Counters {
 public:
  explicit Counters(std::shared_ptr<spdlog::logger> log) : log_(std::move(log)) {}
  /// Counts one occurrence of `reason` and logs `message` (rate-limited per reason).
  void count(const std::string& reason, const std::string& message) {
    const auto n = ++counts_[reason];
    std::uint64_t suppressed = 0;
    if (!limits_[reason].allow(suppressed)) return;
    if (suppressed > 0) {
      log_->warn("{} (#{} '{}'; {} more since the last message)", message, n, reason, suppressed);
    } else {
      log_->warn("{} (#{} '{}')", message, n, reason);
    }
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
  std::map<std::string, LogRateLimit> limits_;
};

}  // namespace fuse
