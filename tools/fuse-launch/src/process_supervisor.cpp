#include "fuse/launch/process_supervisor.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse::launch {

namespace {
std::string command_line(const std::vector<std::string>& argv) {
  std::string s;
  for (const auto& a : argv) s += (s.empty() ? "" : " ") + a;
  return s;
}

/// A line of the launcher's own in the service's log, between the service's output.
void log_marker(const std::string& log_path, const std::string& text) {
  std::ofstream(log_path, std::ios::app) << "[fuse-launch] " << text << std::endl;
}
}  // namespace

const char* to_string(ServiceState state) {
  switch (state) {
    case ServiceState::running: return "running";
    case ServiceState::restarting: return "restarting";
    case ServiceState::done: return "done";
    case ServiceState::failed: return "failed";
    case ServiceState::stopped: return "stopped";
  }
  return "unknown";
}

ProcessSupervisor::ProcessSupervisor(SupervisorOptions options) : options_(std::move(options)) {
  std::filesystem::create_directories(options_.log_dir);
}

ProcessSupervisor::~ProcessSupervisor() {
  try {
    stop_all(std::chrono::milliseconds(2000));
  } catch (const std::exception& e) {
    logger("launch")->error("stopping the services failed: {}", e.what());
  }
}

void ProcessSupervisor::start(const ServiceSpec& spec) {
  if (spec.name.empty() || services_.count(spec.name)) {
    throw std::invalid_argument("service name '" + spec.name + "' is empty or already used");
  }
  Service s;
  s.spec = spec;
  s.report.name = spec.name;
  s.report.log_path = (std::filesystem::path(options_.log_dir) / (spec.name + ".log")).string();
  spawn(s);
  services_.emplace(spec.name, std::move(s));
  order_.push_back(spec.name);
}

void ProcessSupervisor::spawn(Service& s) {
  log_marker(s.report.log_path, "start " + std::to_string(s.report.restarts + 1) + ": " + command_line(s.spec.argv));
  s.process = Process::spawn(s.spec.argv, s.report.log_path);
  s.started_at = std::chrono::steady_clock::now();
  s.report.state = ServiceState::running;
  logger("launch")->info("{} started (pid {}), log {}", s.spec.name, s.process->pid(), s.report.log_path);
}

void ProcessSupervisor::reap(Service& s) {
  if (s.report.state != ServiceState::running || !s.process) return;
  if (const auto status = s.process->poll()) on_exit(s, *status);
}

void ProcessSupervisor::on_exit(Service& s, const ExitStatus& status) {
  auto log = logger("launch");
  s.process.reset();
  s.report.last_exit = status;
  const auto now = std::chrono::steady_clock::now();
  // A run that lasted healthy_after was not part of a crash loop: backoff and count start over.
  if (now - s.started_at >= options_.healthy_after) s.report.early_deaths = 0;
  const bool fixable = status.signaled || std::find(options_.never_restart.begin(), options_.never_restart.end(),
                                                    status.code) == options_.never_restart.end();
  if (s.spec.exit_zero_is_done && status.success()) {
    s.report.state = ServiceState::done;
    log->info("{} finished", s.spec.name);
  } else if (s.spec.restart && fixable && s.report.early_deaths < options_.max_restarts) {
    const auto backoff =
        std::min(options_.max_backoff, options_.restart_backoff * (1 << std::min(s.report.early_deaths, 16)));
    ++s.report.early_deaths;
    s.report.state = ServiceState::restarting;
    s.restart_at = now + backoff;
    log->warn("{} died unexpectedly ({}); restart in {} ms ({} of at most {} in a row)", s.spec.name, status.describe(),
              backoff.count(), s.report.early_deaths, options_.max_restarts);
  } else {
    s.report.state = ServiceState::failed;
    if (!s.spec.restart) {
      s.report.failure = status.describe();
    } else if (!fixable) {
      s.report.failure = status.describe() + (status.code == kExitUsage ? " (usage or config error)" : " (input cannot be read)") +
                         ": restarting cannot fix it";
    } else {
      s.report.failure = status.describe() + ": " + std::to_string(s.report.early_deaths) +
                         " early deaths in a row, no restarts left";
    }
    log->error("{} failed: {}", s.spec.name, s.report.failure);
  }
}

void ProcessSupervisor::restart(Service& s) {
  ++s.report.restarts;
  try {
    spawn(s);
  } catch (const std::exception& e) {
    s.report.state = ServiceState::failed;
    logger("launch")->error("{} could not be restarted: {}", s.spec.name, e.what());
  }
}

void ProcessSupervisor::poll() {
  const auto now = std::chrono::steady_clock::now();
  for (const auto& name : order_) {
    Service& s = services_.at(name);
    reap(s);
    if (s.report.state == ServiceState::restarting && now >= s.restart_at) restart(s);
  }
}

std::optional<ExitStatus> ProcessSupervisor::wait(const std::string& name, std::chrono::milliseconds timeout) {
  Service& s = find(name);
  if (s.report.state != ServiceState::running || !s.process) return std::nullopt;
  const auto status = s.process->wait_for(timeout);
  if (status) on_exit(s, *status);
  return status;
}

ServiceReport ProcessSupervisor::stop(const std::string& name, std::chrono::milliseconds timeout) {
  Service& s = find(name);
  reap(s);  // an exit that happened before the stop is classified as such
  if (s.report.state == ServiceState::running && s.process) {
    const Process::Termination t = s.process->terminate(timeout);
    s.process.reset();
    s.report.last_exit = t.status;
    s.report.escalated = t.escalated;
    s.report.state = ServiceState::stopped;
    auto log = logger("launch");
    if (t.escalated) {
      log->error("{} ignored SIGTERM for {} ms and was killed", name, timeout.count());
    } else {
      log->info("{} stopped ({})", name, t.status.describe());
    }
  } else if (s.report.state == ServiceState::restarting) {
    s.report.state = ServiceState::stopped;
    s.report.down_at_stop = true;
  }
  return s.report;
}

std::vector<ServiceReport> ProcessSupervisor::stop_all(std::chrono::milliseconds timeout) {
  std::vector<ServiceReport> reports;
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) reports.push_back(stop(*it, timeout));
  return reports;
}

bool ProcessSupervisor::signal(const std::string& name, int sig) {
  Service& s = find(name);
  return s.process && s.process->signal(sig);
}

bool ProcessSupervisor::is_running(const std::string& name) {
  Service& s = find(name);
  reap(s);
  return s.report.state == ServiceState::running;
}

ServiceState ProcessSupervisor::state(const std::string& name) const { return find(name).report.state; }
int ProcessSupervisor::restarts(const std::string& name) const { return find(name).report.restarts; }
std::string ProcessSupervisor::log_path(const std::string& name) const { return find(name).report.log_path; }
ServiceReport ProcessSupervisor::report(const std::string& name) const { return find(name).report; }

pid_t ProcessSupervisor::pid(const std::string& name) const {
  const Service& s = find(name);
  return s.process ? s.process->pid() : -1;
}

ProcessSupervisor::Service& ProcessSupervisor::find(const std::string& name) {
  auto it = services_.find(name);
  if (it == services_.end()) throw std::invalid_argument("no service named '" + name + "'");
  return it->second;
}

const ProcessSupervisor::Service& ProcessSupervisor::find(const std::string& name) const {
  auto it = services_.find(name);
  if (it == services_.end()) throw std::invalid_argument("no service named '" + name + "'");
  return it->second;
}

}  // namespace fuse::launch
