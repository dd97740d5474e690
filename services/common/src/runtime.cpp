#include "fuse/service/runtime.hpp"

#include <pthread.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <csignal>
#include <stdexcept>
#include <thread>

#include "fuse/core/cpu_latency.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/core/scheduling.hpp"

namespace fuse::service {

namespace {
std::atomic<bool> g_stop{false};
std::mutex g_stop_mutex;
std::condition_variable g_stop_changed;
}

ServiceArgs parse_args(int argc, char** argv, const std::set<std::string>& allowed) {
  ServiceArgs args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) != 0) throw std::invalid_argument("unexpected argument '" + a + "'");
    const std::string name = a.substr(2);
    if (i + 1 >= argc) throw std::invalid_argument("option '" + a + "' needs a value");
    const std::string value = argv[++i];
    if (name == "config") {
      args.config_file = value;
    } else if (name == "set") {
      args.overrides.push_back(value);
    } else if (name == "log-level") {
      args.log_level = value;
    } else if (allowed.count(name)) {
      args.options[name] = value;
    } else {
      throw std::invalid_argument("unknown option '" + a + "'");
    }
  }
  if (args.config_file.empty()) throw std::invalid_argument("--config FILE is required");
  return args;
}

void install_signal_handling() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  std::thread([set] {
    pthread_setname_np(pthread_self(), "fuse-signals");  // started before the config is read
    int sig = 0;
    sigwait(&set, &sig);
    {
      std::lock_guard<std::mutex> lock(g_stop_mutex);
      g_stop = true;
    }
    g_stop_changed.notify_all();
  }).detach();
}

bool stop_requested() { return g_stop; }

bool wait_for_stop(double seconds) {
  // Wakes at the deadline itself (a real-time replay publishes on it), or at once on a stop.
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
  std::unique_lock<std::mutex> lock(g_stop_mutex);
  return g_stop_changed.wait_until(lock, end, [] { return g_stop.load(); });
}

bool start_service(const std::string& name, int argc, char** argv, const std::set<std::string>& allowed,
                   ServiceArgs& args, SystemConfig& config, int& exit_code) {
  install_signal_handling();
  try {
    args = parse_args(argc, argv, allowed);
    set_log_level(args.log_level);
    config = load_system_config(args.config_file, args.overrides);
  } catch (const std::exception& e) {
    logger(name)->error("{}", e.what());
    exit_code = 2;
    return false;
  }
  logger(name)->info("config {} loaded; transport {} domain {}", args.config_file, config.transport.vendor,
                     config.transport.domain_id);
  // Before any thread is started, so that all of the service's threads inherit it.
  if (const int slice_us = config.scheduling.slice_us(name); slice_us > 0) {
    const SliceRequest r = request_scheduler_slice(slice_us);
    if (r.applied) {
      logger(name)->info("scheduler slice {} us (scheduling.*_slice_us)", slice_us);
    } else {
      logger(name)->warn("scheduler slice {} us not applied, running with the kernel's default: {}", slice_us, r.message);
    }
  }
  if (config.scheduling.cpu_latency_us >= 0) {
    // Held until the process exits (the kernel drops the request with the file).
    static std::optional<CpuLatencyRequest> held;
    held.emplace(config.scheduling.cpu_latency_us);
    if (held->applied()) {
      logger(name)->info("CPU wake-up latency bound {} us held (scheduling.cpu_latency_us)", config.scheduling.cpu_latency_us);
    } else {
      logger(name)->warn("CPU wake-up latency bound {} us not applied, idle CPUs may sleep deeply: {}",
                         config.scheduling.cpu_latency_us, held->message());
    }
  }
  return true;
}

}  // namespace fuse::service
