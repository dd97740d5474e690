// Static initialisation: while the sensor rests, the mean gyro is the gyro bias and the mean
// specific force points against gravity: R_WI·ā = −g/|g|·|ā| fixes roll and pitch (yaw = 0).
#pragma once

#include <limits>
#include <optional>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/state.hpp"

namespace fuse {

struct StaticInitConfig {
  double duration_s = 1.0;      ///< rest needed before starting
  double max_gyro_std = 0.02;   ///< rad/s: above this the window counts as moving
  double max_accel_std = 0.2;   ///< m/s²: likewise for the specific force
  void load(ConfigNode& node);
};

class StaticInitializer {
 public:
  explicit StaticInitializer(const StaticInitConfig& config) : config_(config) {}
  /// Feeds one sample; returns the initial state once a long enough still window is seen.
  std::optional<NavState> add(const ImuSample& imu, double gravity_magnitude);
  std::size_t restarts() const { return restarts_; }
  /// Time of the sample before the one that completed the still window (the last initial state's
  /// time): a scan that ends after it is covered by the initialising sample, at rest; NaN before one.
  double rest_since() const { return rest_since_; }

 private:
  StaticInitConfig config_;
  std::vector<ImuSample> window_;
  double rest_since_ = std::numeric_limits<double>::quiet_NaN();
  std::size_t restarts_ = 0;
};

}  // namespace fuse
