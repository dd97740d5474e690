#include "fuse/core/progress.hpp"

#include <algorithm>

#include "fuse/core/logging.hpp"

namespace fuse {

Progress::Progress(std::string logger, std::optional<std::uint64_t> total, double period_s)
    : logger_(std::move(logger)), total_(total), period_s_(period_s), next_s_(period_s) {}

std::string Progress::line(std::uint64_t done, double t, double wall_s, const std::string& detail) const {
  std::string s;
  double fraction = 0.0;
  if (total_ && *total_ > 0) {
    fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(*total_));
    s = fmt::format("{:.0f} % ({} of {})", 100.0 * fraction, done, *total_);
  } else {
    s = fmt::format("{} done", done);
  }
  s += fmt::format(" in {:.1f} s", wall_s);
  if (t >= 0.0 && first_t_ >= 0.0 && wall_s > 0.0) {
    s += fmt::format(", {:.1f} s of data ({:.1f}x real time)", t - first_t_, (t - first_t_) / wall_s);
  }
  if (fraction > 0.0) s += fmt::format(", about {:.0f} s left", wall_s * (1.0 - fraction) / fraction);
  if (!detail.empty()) s += ", " + detail;
  return s;
}

void Progress::update(std::uint64_t done, double t, const std::string& detail) {
  if (t >= 0.0 && first_t_ < 0.0) first_t_ = t;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (wall < next_s_) return;
  next_s_ = wall + period_s_;
  logger(logger_)->info("progress: {}", line(done, t, wall, detail));
}

}  // namespace fuse
