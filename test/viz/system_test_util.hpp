// What the live-view and ROS 2 system tests share: where the binaries, the data and the outputs
// are, reading a log, and waiting for a condition with a deadline.
#pragma once

#include <chrono>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

namespace fuse::viz_test {

inline const std::string kBin = FUSE_BIN_DIR;
/// The 20 s corridor of the fuse_sim_data fixture.
inline const std::string kRecording = std::string(FUSE_TEST_DATA) + "/corridor20/recording.mcap";
inline const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
inline const std::string kOut = FUSE_TEST_OUT;

inline std::string read_file(const std::string& path) {
  std::ifstream f(path);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

/// A service's command line: the binary, the config, the domain and health period every test
/// sets, the test's own `sets` (key=value), then `more`.
inline std::vector<std::string> service_argv(const std::string& service, int domain,
                                             const std::vector<std::string>& sets, const std::vector<std::string>& more) {
  std::vector<std::string> argv{kBin + "/" + service, "--config", kConfig, "--set",
                                "transport.domain_id=" + std::to_string(domain), "--set", "health.period_s=0.2"};
  for (const std::string& kv : sets) argv.insert(argv.end(), {"--set", kv});
  argv.insert(argv.end(), more.begin(), more.end());
  return argv;
}

/// Polls `pred` every 50 ms until it holds (true) or `timeout` passed (false).
template <class Pred>
bool wait_until(Pred pred, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return true;
}

}  // namespace fuse::viz_test
