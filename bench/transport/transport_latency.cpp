// Round-trip latency of 1 KiB, 100 KiB and 1 MiB samples on loopback, per vendor: this program
// starts itself as an echo process (same or other vendor) and times ping -> pong, one sample in
// flight. Prints median and p99 of the round trip and half the median as the one-way estimate.
//
//   fuse_transport_latency [domain_id]      (default 28; the echo runs as a child process:
//                                            the same binary with the hidden --echo VENDOR DOMAIN)
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "fuse/cli/cli.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/transport/msg_traits.hpp"

extern char** environ;

namespace {

using namespace fuse::transport;
using Clock = std::chrono::steady_clock;

const char* kPing = "bench/ping";
const char* kPong = "bench/pong";
const TopicQos kQos{Reliability::kReliable, Durability::kVolatile, 4};

TypeSupport bench_type() { return type_support<fuse_msgs::LidarScan>(); }

TransportConfig config(const std::string& vendor, int domain) {
  TransportConfig c;
  c.vendor = vendor;
  c.domain_id = domain;
  return c;
}

/// Echoes every ping back as a pong until a 4-byte sample (stop) or 120 s.
int run_echo(const std::string& vendor, int domain) {
  auto participant = make_participant(config(vendor, domain), "bench-echo");
  auto pong = participant->create_writer(kPong, bench_type(), kQos);
  std::mutex mutex;
  std::condition_variable cv;
  bool stop = false;
  auto ping = participant->create_reader(kPing, bench_type(), kQos, [&](const std::uint8_t* data, std::size_t size) {
    if (size <= 4) {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
      cv.notify_all();
      return;
    }
    pong->write(Bytes(data, data + size));
  });
  std::unique_lock<std::mutex> lock(mutex);
  cv.wait_for(lock, std::chrono::seconds(120), [&] { return stop; });
  return 0;
}

pid_t spawn_echo(const char* self, const std::string& vendor, int domain) {
  std::string exe = self, flag = "--echo", d = std::to_string(domain);
  std::string v = vendor;
  char* argv[] = {exe.data(), flag.data(), v.data(), d.data(), nullptr};
  pid_t pid = -1;
  if (posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv, environ) != 0) return -1;
  return pid;
}

Bytes make_payload(std::size_t bytes) {
  fuse_msgs::LidarScan scan;
  scan.frame("bench");
  const std::size_t overhead = serialize(scan).size();
  scan.points().resize(bytes > overhead ? (bytes - overhead) / 24 : 0);
  for (std::size_t i = 0; i < scan.points().size(); ++i) scan.points()[i].x(static_cast<float>(i));
  return serialize(scan);
}

struct Stats {
  double median_us, p99_us;
};

Stats percentiles(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))]; };
  return Stats{at(0.5), at(0.99)};
}

void run_pair(const char* self, const std::string& vendor, const std::string& echo_vendor, int domain) {
  const pid_t child = spawn_echo(self, echo_vendor, domain);
  if (child < 0) {
    std::printf("%s: could not start the echo process\n", vendor.c_str());
    return;
  }
  {
    auto participant = make_participant(config(vendor, domain), "bench-ping");
    std::mutex mutex;
    std::condition_variable cv;
    std::size_t pongs = 0;
    auto ping = participant->create_writer(kPing, bench_type(), kQos);
    auto pong = participant->create_reader(kPong, bench_type(), kQos, [&](const std::uint8_t*, std::size_t) {
      std::lock_guard<std::mutex> lock(mutex);
      ++pongs;
      cv.notify_all();
    });
    const auto deadline = Clock::now() + std::chrono::seconds(15);
    while ((ping->matched_readers() == 0 || pong->matched_writers() == 0) && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const std::string label = vendor == echo_vendor ? vendor : vendor + " -> " + echo_vendor;
    // Matched here does not yet mean matched there: ping until the first pong comes back.
    bool live = false;
    const Bytes hello = make_payload(64);
    while (!live && Clock::now() < deadline) {
      std::unique_lock<std::mutex> lock(mutex);
      const std::size_t before = pongs;
      lock.unlock();
      ping->write(hello);
      lock.lock();
      live = cv.wait_for(lock, std::chrono::milliseconds(200), [&] { return pongs > before; });
    }
    if (!live) {
      std::printf("%-24s echo process not discovered\n", label.c_str());
    } else {
      struct Size {
        const char* name;
        std::size_t bytes;
        int count;
      };
      for (const Size s : {Size{"1 KiB", 1024, 1000}, Size{"100 KiB", 100 * 1024, 300}, Size{"1 MiB", 1024 * 1024, 100}}) {
        const Bytes payload = make_payload(s.bytes);
        std::vector<double> rtt;
        int lost = 0;
        for (int i = -10; i < s.count; ++i) {  // 10 warm-up round trips
          std::unique_lock<std::mutex> lock(mutex);
          const std::size_t before = pongs;
          lock.unlock();
          const auto t0 = Clock::now();
          ping->write(payload);
          lock.lock();
          if (!cv.wait_for(lock, std::chrono::seconds(2), [&] { return pongs > before; })) {
            ++lost;
            continue;
          }
          const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
          if (i >= 0) rtt.push_back(us);
        }
        if (rtt.empty()) {
          std::printf("%-24s %-8s no round trip completed\n", label.c_str(), s.name);
          continue;
        }
        const Stats st = percentiles(rtt);
        std::printf("%-24s %-8s (%7zu B)  round trip median %8.1f us  p99 %8.1f us  one-way ~%8.1f us%s\n",
                    label.c_str(), s.name, payload.size(), st.median_us, st.p99_us, st.median_us / 2,
                    lost ? "  (some round trips timed out)" : "");
      }
    }
    ping->write(Bytes{0, 1, 0, 0});  // stop the echo
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  int status = 0;
  for (int i = 0; i < 50 && waitpid(child, &status, WNOHANG) == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (waitpid(child, &status, WNOHANG) == 0) {
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
  }
}

/// The command line: the domain of the runs, or (internal) the echo side this program starts.
struct Arguments {
  int domain = 28;
  std::optional<std::pair<std::string, int>> echo;  ///< --echo VENDOR DOMAIN
};

/// The --echo values (VENDOR DOMAIN) into `a`; an error message when they do not check.
std::string take_echo(const std::vector<std::string>& echo, Arguments& a) {
  int domain = -1;
  if (echo.size() != 2) return "--echo: expected VENDOR DOMAIN";
  if (echo[0] != "fastdds" && echo[0] != "cyclonedds") return "--echo: unknown vendor " + echo[0];
  if (!CLI::detail::lexical_cast(echo[1], domain) || domain < 0 || domain > 101) {
    return "--echo: domain '" + echo[1] + "' not in [0, 101]";
  }
  a.echo = std::make_pair(echo[0], domain);
  return "";
}

/// Parses argv into `a`. std::nullopt: go on; otherwise the exit code to end with.
std::optional<int> parse(int argc, char** argv, Arguments& a) {
  const auto app = fuse::cli::make_app(
      "fuse_transport_latency",
      "Round-trip latency of 1 KiB, 100 KiB and 1 MiB samples on loopback, per vendor (fastdds, cyclonedds, "
      "fastdds -> cyclonedds): starts itself as the echo process and times ping -> pong, one sample in flight.");
  app->add_option("domain_id", a.domain, "DDS domain of the runs (default 28)")
      ->type_name("N")
      ->check(CLI::Range(0, 101));
  std::vector<std::string> echo;
  app->add_option("--echo", echo, "internal: be the echo process of VENDOR on DOMAIN (spawn_echo)")
      ->expected(2)
      ->allow_extra_args(false)
      ->group("");  // hidden from --help
  if (const std::optional<int> code = fuse::cli::parse(*app, argc, argv)) return code;
  if (echo.empty()) return std::nullopt;
  if (const std::string error = take_echo(echo, a); !error.empty()) return fuse::cli::usage_error(*app, error);
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  fuse::set_log_level("error");
  Arguments a;
  if (const std::optional<int> code = parse(argc, argv, a)) return *code;
  if (a.echo) return run_echo(a.echo->first, a.echo->second);
  std::printf("transport round trips on loopback (UDP, %zu B socket buffers), one sample in flight\n",
              TransportConfig{}.socket_buffer_bytes);
  run_pair(argv[0], "fastdds", "fastdds", a.domain);
  run_pair(argv[0], "cyclonedds", "cyclonedds", a.domain);
  run_pair(argv[0], "fastdds", "cyclonedds", a.domain);
  return 0;
}
