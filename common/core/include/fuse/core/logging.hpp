// One spdlog logger per component ("run", "sim", "estimator", ...), all sharing one sink.
#pragma once

#include <spdlog/spdlog.h>

#include <memory>
#include <string>

namespace fuse {

/// Returns the logger of a component, creating it on first use (stderr, colour).
std::shared_ptr<spdlog::logger> logger(const std::string& component);

/// Sets the level of every logger, from "trace", "debug", "info", "warn", "error", "off".
/// Throws std::invalid_argument on an unknown level name.
void set_log_level(const std::string& level);

}  // namespace fuse
