#include "fuse/service/runtime.hpp"

#include <pthread.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <csignal>
#include <stdexcept>
#include <thread>

#include "fuse/cli/cli.hpp"
#include "fuse/core/cpu_latency.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/core/scheduling.hpp"

namespace fuse::service {

namespace {
std::atomic<bool> g_stop{false};
std::mutex g_stop_mutex;
std::condition_variable g_stop_changed;
}

std::optional<int> parse_args(const ServiceCli& cli, int argc, char** argv, ServiceArgs& args) {
  const auto app = cli::make_app(cli.name, cli.description, cli.footer);
  app->add_option("--config", args.config_file, "the system config (YAML), validated at start-up")
      ->type_name("FILE")
      ->required();
  const cli::TransportFlags transport(*app);
  app->add_option("--log-level", args.log_level, "trace|debug|info|warn|error (default info)")->type_name("L");
  std::map<std::string, std::string> own;
  for (const OptionSpec& o : cli.options) {
    app->add_option("--" + o.name, own[o.name], o.help)->type_name(o.value_name);
  }
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  for (const OptionSpec& o : cli.options) {
    if (app->count("--" + o.name) > 0) args.options[o.name] = own[o.name];
  }
  args.overrides = transport.overrides();
  return std::nullopt;
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

bool start_service(const ServiceCli& cli, int argc, char** argv, ServiceArgs& args, SystemConfig& config,
                   int& exit_code) {
  const std::string& name = cli.name;
  if (const std::optional<int> code = parse_args(cli, argc, argv, args)) {
    exit_code = *code;
    return false;
  }
  install_signal_handling();
  try {
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
