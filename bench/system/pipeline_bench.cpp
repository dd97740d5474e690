// fuse-bench-pipeline: latency figures of the running multi-process pipeline, measured from
// outside by a test-side participant while fuse-ingest replays a recording in REAL TIME.
//
//   fuse-bench-pipeline --config FILE [--set key=value]... [--domain N] [--vendor V]
//                       --start-wall UNIX_S [--rate R] (--input RECORDING | --t0 T --duration S)
//                       [--warmup-s S] [--tail-s S] [--idle-query-s S] [--query-hz HZ] [--query-lag-ms MS]
//                       [--query-deadline-ms MS] [--query-slice-us US] [--no-query] [--no-breakdown]
//                       [--observe-scan]
//                       [--csv PREFIX]
//   fuse-bench-pipeline --config FILE [--set key=value]... --lockstep-scans N [--idle-s S]
//   fuse-bench-pipeline --codec --input RECORDING
//
// --start-wall and --rate must be the ones fuse-ingest was given. t0 (the recording's first
// event time, which ingest's schedule starts from) is read from the recording with the same
// io::open_sensor_source ingest uses, or given with --t0 (then --duration bounds the run).
// The transport settings (vendor, domain, buffers) come from the config, as for the services.
//
// Every wall time below is UNIX time (std::chrono::system_clock), the clock fuse-ingest's
// schedule uses; all processes run on one machine, so there is no clock offset between them.
// The schedule of an event with data time t is  sched(t) = start_wall + (t − t0) / rate.
//
// Figures (one "key: value" line each; times in milliseconds):
//
// (a) query_*: round trip of the planner client library (fuse::query::Client, the installed
//     API) against fuse-state's `query` RPC, called at --query-hz (1 kHz) alternately as
//     latest() and at(t) for a recent t (the data time that is "now" on the schedule minus
//     --query-lag-ms). Measured with steady_clock around the blocking call: request
//     serialisation, DDS write, fuse-state's receive thread (it answers inline), its mutex (held
//     also while it propagates IMU and re-propagates after a correction), the history query,
//     the reply's way back and the client's wake-up. A call that gets no reply within
//     --query-deadline-ms counts as an error (unavailable), as does any non-ok reply. The
//     calls are paced, not back to back: a call that overruns its 1 ms slot delays the next
//     one (missed slots are not made up in a burst).
//     The client's transport threads and the calling thread (the planner's) request a scheduler
//     slice of --query-slice-us (100; 0 = the kernel's default), as fuse-state does with
//     scheduling.state_slice_us: they then preempt a busy thread when they wake (Linux 6.12+).
//     query_idle_rtt_*: the same calls for --idle-query-s (5 s) after the replay and its tail,
//     against the same services, now idle: the baseline of the machine and transport at
//     that moment, without the pipeline's own load.
//
// (b) odometry_latency_*: receive wall time (in this process's subscriber callback, after CDR
//     decoding) of the StateEstimate fuse-state publishes for the IMU sample of data time t,
//     minus sched(t). It includes fuse-ingest's scheduling error (its wait wakes at the
//     event's time; the wake-up is late by the scheduler's latency, more when the machine is
//     busy), the IMU sample's DDS hop ingest -> state, fuse-state's decoding, lock and propagation, and the odometry hop
//     state -> this process. state/odometry is best-effort: samples lost on the way are
//     counted as missing, not as late.
//
// (c) correction_latency_*: receive wall time of the Correction for the scan that ends at
//     t_end, minus sched(t_end) (a scan "arrives" at its end time, and ingest publishes it
//     then). It includes ingest's scheduling error, the scan's DDS hop to fuse-update (a
//     ~0.5 MB sample), the queue behind a previous scan still in work, the `history` RPC to
//     fuse-state (including its waits until the IMU covers t_end), deskew, association and
//     the update, and the Correction's hop to this process. Only scans fuse-update processed
//     (updated or prior-only) count; skipped scans are counted apart.
//
// Breakdown of (c) (unless --no-breakdown): this process also listens to the `history` RPC's
// request and reply topics and to `imu`, all small samples:
//   imu_hop_latency_*           IMU sample received here minus sched(t): ingest's scheduling
//                               error plus one DDS hop (a reference for (b))
//   scan_to_history_request_*   first history request for a scan seen here minus sched(t_end):
//                               scheduling, the scan's hop and decoding in fuse-update, and
//                               the wait behind the previous scan
//   history_rpc_*               first request seen -> first ok reply seen: the history RPC
//                               round trip, NOT_READY retries (1 ms apart) included
//   history_not_ready_per_scan_mean  NOT_READY replies per scan (IMU not yet covering t_end)
//   history_reply_to_correction_*    ok reply seen -> Correction seen: fuse-update's decoding of
//                               the reply, deskew, association, update and publishing
//   update_ms_*                 the estimator's own per-scan time, as fuse-update reports it
//                               in Correction.update_ms
// With --observe-scan (off by default: a second reader of the ~0.5 MB scans makes fuse-ingest
// send each scan twice and adds load, so it perturbs what it measures a little):
//   scan_hop_latency_*          scan received and decoded here minus sched(t_end): ingest's
//                               scheduling error, its conversion and serialisation of the
//                               scan, and one DDS hop of the scan
// --csv PREFIX writes the raw samples behind the figures: PREFIX-scans.csv (per scan: its
// schedule and when its history request, ok reply and Correction were seen, ms after
// --start-wall), PREFIX-odometry.csv (data time, latency) and PREFIX-queries.csv (call start
// ms after --start-wall, kind, round trip, ok).
// The bench sees each message at about the same moment as its real reader (loopback, one
// extra copy), so the sections are close to, not exactly, what the services experience.
//
// Lockstep throughput (--lockstep-scans N): start this before a lockstep replay; it only
// listens to update/correction and prints lockstep_corrections, lockstep_replay_s (first to
// last Correction received here: the pipeline's processing of the recording, without process
// start-up, discovery, the map sync and shut-down) and lockstep_scans_per_s
// ((corrections − 1) / replay_s). It ends after N corrections, after --idle-s without one
// (once one came), or on SIGINT/SIGTERM.
//
// Scan codec cost (--codec --input REC, no transport): per scan of the recording, the CPU time
// of the conversions a scan goes through on its way from fuse-ingest into fuse-update's
// estimator. codec_*: through the generated type, service::to_msg (estimator scan -> wire
// type), transport::serialize (Fast CDR), transport::deserialize and service::from_msg (with
// its checks). codec_direct_*: the path the services take, the direct codec
// (service::scan_to_wire; io::decode_scan + service::check_scan), with a count of scans whose
// bytes differ from Fast CDR's (must be 0). Prints the medians and the serialised size: the
// part of the scan hop that is not the DDS transfer itself. It also times SensorSource::next()
// per event over the whole recording (read_*): fuse-ingest reads ahead on its own thread
// (io::PrefetchSource), so a slow read no longer delays the schedule.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fuse/cli/cli.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/core/scheduling.hpp"
#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/query/client.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/rpc.hpp"

namespace {

using SteadyClock = std::chrono::steady_clock;

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

/// Sleeps until the UNIX time `until` (or a stop); false when stopped.
bool sleep_until_unix(double until) {
  while (!g_stop) {
    const double left = until - unix_now();
    if (left <= 0.0) return true;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left, 0.1)));
  }
  return false;
}

struct Options {
  std::string config_file;
  std::vector<std::string> overrides;
  std::string input;
  std::optional<double> start_wall, t0, duration;
  double rate = 1.0;
  double warmup_s = 2.0;
  double tail_s = 3.0;
  double idle_query_s = 5.0;
  double query_hz = 1000.0;
  double query_lag_ms = 20.0;
  int query_deadline_ms = 200;
  int query_slice_us = 100;
  bool query = true;
  bool breakdown = true;
  bool observe_scan = false;
  std::string csv;
  std::optional<std::size_t> lockstep_scans;
  bool codec = false;
  double idle_s = 10.0;
};

/// The options of the real-time attach mode: the schedule and the window measured.
void add_schedule_options(CLI::App& app, Options& o) {
  app.add_option("--input", o.input, "the recording fuse-ingest replays (t0 and the window come from it)")
      ->type_name("RECORDING");
  app.add_option("--start-wall", o.start_wall, "the --start-wall fuse-ingest was given (UNIX time)")
      ->type_name("UNIX_S")->check(fuse::cli::finite_number());
  app.add_option("--rate", o.rate, "the --rate fuse-ingest was given (default 1)")->type_name("R")->check(fuse::cli::finite_number());
  app.add_option("--t0", o.t0, "the recording's first event time, instead of reading --input")
      ->type_name("T")->check(fuse::cli::finite_number());
  app.add_option("--duration", o.duration, "data seconds after t0 to measure (with --t0)")
      ->type_name("S")->check(fuse::cli::finite_number());
  app.add_option("--warmup-s", o.warmup_s, "data seconds after t0 not measured (default 2)")
      ->type_name("S")->check(fuse::cli::finite_number());
  app.add_option("--tail-s", o.tail_s, "wait after the window for the last answers (default 3)")
      ->type_name("S")->check(fuse::cli::finite_number());
  app.add_option("--csv", o.csv, "write the raw samples to PREFIX-{scans,odometry,queries}.csv")->type_name("PREFIX");
  app.add_flag_callback("--no-breakdown", [&o] { o.breakdown = false; }, "do not listen to imu and the history RPC");
  app.add_flag("--observe-scan", o.observe_scan, "also read the scans (their hop; perturbs a little)");
}

/// The options of the query client's calls (section (a)).
void add_query_options(CLI::App& app, Options& o) {
  app.add_option("--query-hz", o.query_hz, "query calls per second (default 1000)")->type_name("HZ")->check(fuse::cli::finite_number());
  app.add_option("--query-lag-ms", o.query_lag_ms, "at(t) asks for 'now' on the schedule minus this (default 20)")
      ->type_name("MS")->check(fuse::cli::finite_number());
  app.add_option("--query-deadline-ms", o.query_deadline_ms, "a call without a reply by then is an error (default 200)")
      ->type_name("MS");
  app.add_option("--query-slice-us", o.query_slice_us,
                 "scheduler slice of the client's threads; 0 = kernel default (default 100)")
      ->type_name("US");
  app.add_option("--idle-query-s", o.idle_query_s, "the idle baseline's calls after the replay (default 5)")
      ->type_name("S")->check(fuse::cli::finite_number());
  app.add_flag_callback("--no-query", [&o] { o.query = false; }, "make no query calls");
}

/// The other two modes: lockstep throughput and the scan codec's cost.
void add_mode_options(CLI::App& app, Options& o) {
  app.add_option_function<long long>(
         "--lockstep-scans",
         [&o](long long n) {
           if (n < 1) throw CLI::ValidationError("--lockstep-scans", "must be at least 1");
           o.lockstep_scans = static_cast<std::size_t>(n);
         },
         "lockstep throughput: end after N corrections")
      ->type_name("N");
  app.add_option("--idle-s", o.idle_s, "lockstep: end after this long without a correction (default 10)")
      ->type_name("S")->check(fuse::cli::finite_number());
  app.add_flag("--codec", o.codec, "scan codec cost on --input (no transport)");
}

/// What the options do not allow together; empty when they check.
std::string check(const Options& o) {
  if (o.codec) return o.input.empty() ? "--codec needs --input" : "";
  if (o.config_file.empty()) return "--config is required";
  if (o.lockstep_scans) return "";
  if (!o.start_wall) return "--start-wall is required (the one fuse-ingest was given)";
  if (o.input.empty() && !(o.t0 && o.duration)) return "give --input, or --t0 and --duration";
  if (!(o.rate > 0.0)) return "--rate must be positive";
  if (!(o.query_hz > 0.0 && o.query_hz <= 20000.0)) return "--query-hz must be in (0, 20000]";
  if (o.query_deadline_ms <= 0) return "--query-deadline-ms must be positive";
  if (!fuse::valid_scheduler_slice(o.query_slice_us)) return "--query-slice-us must be 0 or in [100, 100000]";
  if (o.warmup_s < 0.0 || o.tail_s < 0.0 || o.query_lag_ms < 0.0) {
    return "--warmup-s, --tail-s and --query-lag-ms must not be negative";
  }
  return "";
}

/// Parses and checks argv into `o`. std::nullopt: go on; otherwise the exit code to end with.
std::optional<int> parse(int argc, char** argv, Options& o) {
  const auto app = fuse::cli::make_app(
      "fuse-bench-pipeline",
      "Attaches to a pipeline replaying in real time (fuse-ingest --mode realtime with the same --start-wall and "
      "--rate); prints query RPC round trip, IMU->odometry and scan->correction latencies as 'key: value' lines "
      "(milliseconds). Or, with --lockstep-scans, times a lockstep replay; or, with --codec, the scan codec.",
      "Modes:\n"
      "  fuse-bench-pipeline --config FILE [--set K=V]... [--domain N] [--vendor V] --start-wall UNIX_S [--rate R]\n"
      "                      (--input RECORDING | --t0 T --duration S) [options]\n"
      "  fuse-bench-pipeline --config FILE [--set K=V]... --lockstep-scans N [--idle-s S]\n"
      "  fuse-bench-pipeline --codec --input RECORDING\n"
      "Exit codes: 0 done, 1 a run that failed or was interrupted, 2 bad arguments or config.");
  app->add_option("--config", o.config_file, "the system config (YAML), as the services were given it")
      ->type_name("FILE");
  const fuse::cli::TransportFlags transport(*app);
  add_schedule_options(*app, o);
  add_query_options(*app, o);
  add_mode_options(*app, o);
  if (const std::optional<int> code = fuse::cli::parse(*app, argc, argv)) return code;
  o.overrides = transport.overrides();
  if (const std::string error = check(o); !error.empty()) return fuse::cli::usage_error(*app, error);
  return std::nullopt;
}

/// What the recording holds, in ingest's terms (arrival times).
struct RecordingInfo {
  double t0 = 0.0;      ///< first event's arrival time: the schedule's origin
  double t_last = 0.0;  ///< last event's arrival time
  std::size_t imu = 0, scans = 0;
  std::vector<double> imu_t, scan_end;  ///< to count what never arrived within the window
};

RecordingInfo read_recording(const std::string& path) {
  RecordingInfo info;
  auto source = fuse::io::open_sensor_source(path);
  fuse::io::SensorEvent ev;
  bool first = true;
  while (source->next(ev)) {
    const double t = ev.arrival_time();
    if (first) info.t0 = t;
    first = false;
    info.t_last = t;
    if (ev.kind == fuse::io::SensorEvent::Kind::kImu) {
      info.imu_t.push_back(t);
    } else {
      info.scan_end.push_back(t);
    }
  }
  if (first) throw std::runtime_error("recording '" + path + "' holds no events");
  info.imu = info.imu_t.size();
  info.scans = info.scan_end.size();
  return info;
}

// ---- statistics --------------------------------------------------------------------------

/// Nearest-rank quantile of sorted values (q in [0, 1]); the median averages the middle two.
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::nan("");
  if (q == 0.5) {
    const std::size_t n = sorted.size();
    return n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  }
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size() - 1, rank == 0 ? 0 : rank - 1)];
}

std::string fixed(double v, int digits = 3) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

void line(const std::string& key, const std::string& value) { std::cout << key << ": " << value << "\n"; }

/// Prints <prefix>_{median,p95,p99,max,mean}_ms (the ones asked for) and <prefix>_count.
void print_stats(const std::string& prefix, std::vector<double> ms, const std::vector<std::string>& which) {
  std::sort(ms.begin(), ms.end());
  line(prefix + "_count", std::to_string(ms.size()));
  for (const std::string& w : which) {
    double v = std::nan("");
    if (w == "median") v = quantile(ms, 0.5);
    if (w == "p95") v = quantile(ms, 0.95);
    if (w == "p99") v = quantile(ms, 0.99);
    if (w == "max") v = ms.empty() ? std::nan("") : ms.back();
    if (w == "min") v = ms.empty() ? std::nan("") : ms.front();
    if (w == "mean" && !ms.empty()) {
      double s = 0.0;
      for (double x : ms) s += x;
      v = s / static_cast<double>(ms.size());
    }
    line(prefix + "_" + w + "_ms", fixed(v));
  }
}

// ---- what the subscribers record ---------------------------------------------------------

struct ScanTrace {
  std::optional<double> first_request_wall;  ///< first history request for this scan seen here
  std::optional<double> ok_reply_wall;       ///< first ok history reply seen here
  std::size_t not_ready = 0;                 ///< NOT_READY replies
  std::optional<double> correction_wall;
  int result = -1;
  double update_ms = 0.0;
};

struct Recorder {
  std::mutex mutex;
  std::vector<double> odometry_ms;   ///< (b), per StateEstimate in the window
  std::vector<double> odometry_t;    ///< its data time
  std::size_t odometry_seen = 0;     ///< every StateEstimate, window or not
  std::vector<double> imu_hop_ms;    ///< breakdown: IMU sample received here
  std::vector<double> scan_hop_ms;   ///< --observe-scan: scan received here
  std::map<double, ScanTrace> scans;  ///< by scan end time
  std::map<std::pair<std::uint64_t, std::uint64_t>, double> request_t_end;  ///< (client, request) -> t_end
  std::size_t corrections_out_of_window = 0;
};

// ---- the query load ----------------------------------------------------------------------

struct QueryFigures {
  std::vector<double> latest_ms, at_ms;
  std::map<std::string, std::size_t> errors;  ///< by kind (error name, "latest"/"at" prefixed)
  std::map<std::string, std::size_t> statuses;
  std::vector<double> slow_wall;  ///< UNIX start time of every call over 1 ms (or failed)
  struct Call {
    double wall, ms;
    bool latest, ok;
  };
  std::vector<Call> log;  ///< every call, with --csv
  std::size_t calls = 0;
  double seconds = 0.0;
};

/// Calls the query service from wall_from to wall_to (UNIX). at(t) asks for "now" on the
/// schedule minus the lag, or for `fixed_t` when given (the idle baseline after the replay).
QueryFigures run_queries(fuse::query::Client& client, const Options& o, double t0, double wall_from, double wall_to,
                         std::optional<double> fixed_t = std::nullopt) {
  QueryFigures f;
  f.latest_ms.reserve(static_cast<std::size_t>((wall_to - wall_from) * o.query_hz / 2.0) + 16);
  f.at_ms.reserve(f.latest_ms.capacity());
  if (!sleep_until_unix(wall_from)) return f;
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(1.0 / o.query_hz));
  auto next = SteadyClock::now();
  const auto begin = next;
  bool latest = true;
  while (!g_stop) {
    const double wall = unix_now();
    if (wall >= wall_to) break;
    fuse::query::Result r;
    const auto a = SteadyClock::now();
    if (latest) {
      r = client.latest();
    } else {
      // "Now" on the schedule, minus a little: a time the history holds.
      const double t = fixed_t ? *fixed_t : t0 + (wall - *o.start_wall) * o.rate - o.query_lag_ms * 1e-3;
      r = client.at(t);
    }
    const auto b = SteadyClock::now();
    const double ms = std::chrono::duration<double, std::milli>(b - a).count();
    ++f.calls;
    if (ms > 1.0 || !r.ok()) f.slow_wall.push_back(wall);
    if (!o.csv.empty()) f.log.push_back({wall, ms, latest, r.ok()});
    const std::string kind = latest ? "latest" : "at";
    if (r.ok()) {
      (latest ? f.latest_ms : f.at_ms).push_back(ms);
      ++f.statuses[kind + "_" + fuse::query::to_string(r.estimate.status)];
    } else {
      ++f.errors[kind + "_" + fuse::query::to_string(r.error)];
    }
    latest = !latest;
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;  // overran the slot: go on at once, do not burst to catch up
    std::this_thread::sleep_until(next);
  }
  f.seconds = std::chrono::duration<double>(SteadyClock::now() - begin).count();
  return f;
}

/// --codec: the CPU cost of a scan's conversions on its way ingest -> update.
int run_codec(const Options& o) {
  using namespace fuse;
  using Ms = std::chrono::duration<double, std::milli>;
  std::vector<double> to_msg_ms, ser_ms, deser_ms, from_msg_ms, bytes, points;
  std::vector<double> direct_encode_ms, direct_decode_ms;  // the path the services take
  std::size_t direct_differs = 0;
  std::vector<double> read_ms;  // per event: SensorSource::next(), as fuse-ingest calls it
  auto source = io::open_sensor_source(o.input);
  io::SensorEvent ev;
  for (;;) {
    const auto r0 = SteadyClock::now();
    if (!source->next(ev)) break;
    read_ms.push_back(Ms(SteadyClock::now() - r0).count());
    if (ev.kind != io::SensorEvent::Kind::kLidar || to_msg_ms.size() >= 200) continue;
    const auto a = SteadyClock::now();
    const fuse_msgs::LidarScan m = service::to_msg(ev.scan, "lidar");
    const auto b = SteadyClock::now();
    const transport::Bytes wire = transport::serialize(m);
    const auto c = SteadyClock::now();
    fuse_msgs::LidarScan back;
    if (!transport::deserialize(wire.data(), wire.size(), back)) {
      std::cerr << "fuse-bench-pipeline: a scan does not decode\n";
      return 1;
    }
    const auto d = SteadyClock::now();
    const LidarScan scan = service::from_msg(back);
    const auto e = SteadyClock::now();
    to_msg_ms.push_back(Ms(b - a).count());
    ser_ms.push_back(Ms(c - b).count());
    deser_ms.push_back(Ms(d - c).count());
    from_msg_ms.push_back(Ms(e - d).count());
    bytes.push_back(static_cast<double>(wire.size()));
    points.push_back(static_cast<double>(scan.points.size()));
    // fuse-ingest: service::scan_to_wire; fuse-update: io::decode_scan, then check_scan.
    const auto f = SteadyClock::now();
    const std::vector<std::uint8_t> direct = service::scan_to_wire(ev.scan, "lidar");
    const auto g = SteadyClock::now();
    LidarScan decoded = io::decode_scan(io::kLidarScanSchemaName, direct.data(), direct.size());
    service::check_scan(decoded);
    const auto h = SteadyClock::now();
    direct_encode_ms.push_back(Ms(g - f).count());
    direct_decode_ms.push_back(Ms(h - g).count());
    if (direct != wire) ++direct_differs;
  }
  auto med = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return quantile(v, 0.5);
  };
  line("codec_scans", std::to_string(to_msg_ms.size()));
  line("codec_points_median", fixed(med(points), 0));
  line("codec_bytes_median", fixed(med(bytes), 0));
  line("codec_to_msg_median_ms", fixed(med(to_msg_ms)));
  line("codec_serialize_median_ms", fixed(med(ser_ms)));
  line("codec_deserialize_median_ms", fixed(med(deser_ms)));
  line("codec_from_msg_median_ms", fixed(med(from_msg_ms)));
  std::vector<double> total(to_msg_ms.size());
  for (std::size_t i = 0; i < total.size(); ++i) total[i] = to_msg_ms[i] + ser_ms[i] + deser_ms[i] + from_msg_ms[i];
  line("codec_total_median_ms", fixed(med(total)));
  line("codec_direct_encode_median_ms", fixed(med(direct_encode_ms)));
  line("codec_direct_decode_check_median_ms", fixed(med(direct_decode_ms)));
  std::vector<double> direct_total(direct_encode_ms.size());
  for (std::size_t i = 0; i < direct_total.size(); ++i) direct_total[i] = direct_encode_ms[i] + direct_decode_ms[i];
  line("codec_direct_total_median_ms", fixed(med(direct_total)));
  line("codec_direct_bytes_differ", std::to_string(direct_differs));
  // Reading the recording: most events come out of an already decoded chunk; the first event
  // of each MCAP chunk pays for reading, checking and decompressing the whole chunk.
  std::sort(read_ms.begin(), read_ms.end());
  std::size_t stalls = 0;
  for (double v : read_ms) stalls += v > 5.0 ? 1 : 0;
  line("read_events", std::to_string(read_ms.size()));
  line("read_event_median_ms", fixed(quantile(read_ms, 0.5), 4));
  line("read_event_max_ms", fixed(read_ms.empty() ? std::nan("") : read_ms.back()));
  line("read_events_over_5ms", std::to_string(stalls));
  double stall_ms = 0.0;
  for (double v : read_ms) stall_ms += v > 5.0 ? v : 0.0;
  line("read_event_over_5ms_mean_ms", fixed(stalls ? stall_ms / static_cast<double>(stalls) : 0.0));
  return 0;
}

/// Lockstep: times the corrections only (see the header comment).
int run_lockstep(const fuse::service::SystemConfig& config, const Options& o) {
  using namespace fuse;
  std::mutex mutex;
  std::optional<double> first, last;
  std::size_t n = 0;
  std::unique_ptr<transport::Participant> participant;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> sub;
  try {
    participant = transport::make_participant(config.transport, "fuse-bench-pipeline");
    sub = std::make_unique<transport::Subscriber<fuse_msgs::Correction>>(
        *participant, transport::topics::kCorrection, [&](const fuse_msgs::Correction&) {
          const double now = unix_now();
          std::lock_guard<std::mutex> lock(mutex);
          if (!first) first = now;
          last = now;
          ++n;
        });
  } catch (const std::exception& e) {
    std::cerr << "fuse-bench-pipeline: transport: " << e.what() << "\n";
    return 1;
  }
  while (!g_stop) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (n >= *o.lockstep_scans) break;
      if (last && unix_now() - *last > o.idle_s) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  sub.reset();
  std::lock_guard<std::mutex> lock(mutex);
  const double span = (first && last) ? *last - *first : 0.0;
  line("lockstep_corrections", std::to_string(n));
  line("lockstep_expected", std::to_string(*o.lockstep_scans));
  line("lockstep_replay_s", fixed(span, 3));
  line("lockstep_scans_per_s", fixed(span > 0.0 ? static_cast<double>(n - 1) / span : std::nan(""), 2));
  std::cout.flush();
  return n >= *o.lockstep_scans ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace fuse;
  Options o;
  if (const std::optional<int> code = parse(argc, argv, o)) return *code;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  set_log_level("warn");
  if (o.codec) {
    try {
      return run_codec(o);
    } catch (const std::exception& e) {
      std::cerr << "fuse-bench-pipeline: " << e.what() << "\n";
      return 1;
    }
  }

  service::SystemConfig config;
  try {
    config = service::load_system_config(o.config_file, o.overrides);
  } catch (const std::exception& e) {
    std::cerr << "fuse-bench-pipeline: config: " << e.what() << "\n";
    return 2;
  }
  if (o.lockstep_scans) return run_lockstep(config, o);

  // The schedule's origin and end, from the recording as ingest reads it (or as given).
  RecordingInfo rec;
  if (!o.input.empty()) {
    try {
      rec = read_recording(o.input);
    } catch (const std::exception& e) {
      std::cerr << "fuse-bench-pipeline: " << e.what() << "\n";
      return 1;
    }
    if (o.t0) rec.t0 = *o.t0;
  } else {
    rec.t0 = *o.t0;
    rec.t_last = *o.t0 + *o.duration;
  }
  const double start_wall = *o.start_wall;
  const auto sched = [&](double t) { return start_wall + (t - rec.t0) / o.rate; };
  const double t_from = rec.t0 + o.warmup_s;  // data times before this are not measured
  const double t_to = o.duration ? std::min(rec.t_last, rec.t0 + *o.duration) : rec.t_last;
  const double wall_from = sched(t_from);
  const double wall_to = sched(t_to);
  if (unix_now() > wall_from) {
    std::cerr << "fuse-bench-pipeline: started after the measurement window opened (start-wall + warmup)\n";
    return 1;
  }

  Recorder rec_;
  const auto in_window = [&](double t) { return t >= t_from && t <= t_to; };
  std::unique_ptr<transport::Participant> participant;
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> odometry_sub;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> correction_sub;
  std::unique_ptr<transport::Subscriber<fuse_msgs::ImuSample>> imu_sub;
  std::unique_ptr<transport::Subscriber<fuse_msgs::HistoryRequest>> history_request_sub;
  std::unique_ptr<transport::Subscriber<fuse_msgs::HistoryReply>> history_reply_sub;
  std::unique_ptr<transport::Subscriber<fuse_msgs::LidarScan>> scan_sub;
  std::unique_ptr<query::Client> client;
  try {
    participant = transport::make_participant(config.transport, "fuse-bench-pipeline");
    odometry_sub = std::make_unique<transport::Subscriber<fuse_msgs::StateEstimate>>(
        *participant, transport::topics::kOdometry, [&](const fuse_msgs::StateEstimate& m) {
          const double now = unix_now();
          std::lock_guard<std::mutex> lock(rec_.mutex);
          ++rec_.odometry_seen;
          if (in_window(m.t())) {
            rec_.odometry_ms.push_back((now - sched(m.t())) * 1e3);
            rec_.odometry_t.push_back(m.t());
          }
        });
    correction_sub = std::make_unique<transport::Subscriber<fuse_msgs::Correction>>(
        *participant, transport::topics::kCorrection, [&](const fuse_msgs::Correction& m) {
          const double now = unix_now();
          std::lock_guard<std::mutex> lock(rec_.mutex);
          if (!in_window(m.t())) {  // includes a transient-local backlog from an earlier run
            ++rec_.corrections_out_of_window;
            return;
          }
          ScanTrace& s = rec_.scans[m.t()];
          if (s.correction_wall) return;  // a repeat
          s.correction_wall = now;
          s.result = static_cast<int>(m.result());
          s.update_ms = m.update_ms();
        });
    if (o.breakdown) {
      imu_sub = std::make_unique<transport::Subscriber<fuse_msgs::ImuSample>>(
          *participant, transport::topics::kImu, [&](const fuse_msgs::ImuSample& m) {
            const double now = unix_now();
            std::lock_guard<std::mutex> lock(rec_.mutex);
            if (in_window(m.t())) rec_.imu_hop_ms.push_back((now - sched(m.t())) * 1e3);
          });
      history_request_sub = std::make_unique<transport::Subscriber<fuse_msgs::HistoryRequest>>(
          *participant, transport::request_topic(transport::services::kHistory), [&](const fuse_msgs::HistoryRequest& m) {
            const double now = unix_now();
            std::lock_guard<std::mutex> lock(rec_.mutex);
            rec_.request_t_end[{m.header().client_id(), m.header().request_id()}] = m.t_end();
            if (!in_window(m.t_end())) return;
            ScanTrace& s = rec_.scans[m.t_end()];
            if (!s.first_request_wall) s.first_request_wall = now;
          });
      history_reply_sub = std::make_unique<transport::Subscriber<fuse_msgs::HistoryReply>>(
          *participant, transport::reply_topic(transport::services::kHistory), [&](const fuse_msgs::HistoryReply& m) {
            const double now = unix_now();
            std::lock_guard<std::mutex> lock(rec_.mutex);
            auto it = rec_.request_t_end.find({m.header().client_id(), m.header().request_id()});
            if (it == rec_.request_t_end.end() || !in_window(it->second)) return;
            ScanTrace& s = rec_.scans[it->second];
            if (m.error() == fuse_msgs::RPC_NOT_READY) ++s.not_ready;
            if (m.error() == fuse_msgs::RPC_OK && !s.ok_reply_wall) s.ok_reply_wall = now;
          });
    }
    if (o.observe_scan) {
      scan_sub = std::make_unique<transport::Subscriber<fuse_msgs::LidarScan>>(
          *participant, transport::topics::kLidarScan, [&](const fuse_msgs::LidarScan& m) {
            const double now = unix_now();
            std::lock_guard<std::mutex> lock(rec_.mutex);
            if (in_window(m.end_time())) rec_.scan_hop_ms.push_back((now - sched(m.end_time())) * 1e3);
          });
    }
    if (o.query) {
      query::ClientOptions co;
      co.vendor = config.transport.vendor;
      co.domain_id = config.transport.domain_id;
      co.loopback_only = config.transport.loopback_only;
      co.max_participants = config.transport.max_participants;
      co.shared_memory = config.transport.shared_memory;
      co.socket_buffer_bytes = config.transport.socket_buffer_bytes;
      co.deadline_ms = o.query_deadline_ms;
      co.participant_name = "fuse-bench-pipeline-query";
      co.system_name = config.transport.system_name;
      co.security = config.transport.security.enabled;
      co.security_keystore = config.transport.security.keystore;
      co.security_private_key = config.transport.security.private_key;
      co.interfaces = config.transport.interfaces;
      co.peers = config.transport.peers;
      co.scheduler_slice_us = o.query_slice_us;
      client = std::make_unique<query::Client>(co);
      // The calling thread is the planner's: it asks for the same slice as the client's threads.
      if (o.query_slice_us > 0 && !fuse::request_scheduler_slice(o.query_slice_us).applied) {
        std::cerr << "fuse-bench-pipeline: scheduler slice not applied (kernel default)\n";
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "fuse-bench-pipeline: transport: " << e.what() << "\n";
    return 1;
  }

  QueryFigures qf;
  if (client) {
    if (!client->wait_for_server(static_cast<int>(std::max(1000.0, (wall_from - unix_now()) * 1e3)))) {
      std::cerr << "fuse-bench-pipeline: no query server by the start of the window\n";
    }
    qf = run_queries(*client, o, rec.t0, wall_from, wall_to);
  }
  sleep_until_unix(wall_to + o.tail_s);  // the last scan's answer, the last odometry
  // Baseline: the same calls against the same, now idle, pipeline (replay over, services up).
  QueryFigures idle;
  if (client && !g_stop && o.idle_query_s > 0.0) {
    const double now = unix_now();
    idle = run_queries(*client, o, rec.t0, now, now + o.idle_query_s, t_to - o.query_lag_ms * 1e-3);
  }
  const bool interrupted = g_stop;
  // Stop the callbacks before reading what they recorded.
  scan_sub.reset();
  history_reply_sub.reset();
  history_request_sub.reset();
  imu_sub.reset();
  correction_sub.reset();
  odometry_sub.reset();
  client.reset();

  // ---- figures ----
  std::lock_guard<std::mutex> lock(rec_.mutex);
  line("rate", fixed(o.rate, 3));
  line("window_data_s", fixed(t_to - t_from, 3));
  line("interrupted", interrupted ? "yes" : "no");
  if (o.query) {
    std::vector<double> all = qf.latest_ms;
    all.insert(all.end(), qf.at_ms.begin(), qf.at_ms.end());
    std::size_t errors = 0;
    for (const auto& [k, n] : qf.errors) errors += n;
    line("query_calls", std::to_string(qf.calls));
    line("query_rate_hz", fixed(qf.seconds > 0.0 ? static_cast<double>(qf.calls) / qf.seconds : 0.0, 1));
    line("query_errors", std::to_string(errors));
    print_stats("query_rtt", all, {"median", "p99", "max"});
    print_stats("query_latest_rtt", qf.latest_ms, {"median", "p99", "max"});
    print_stats("query_at_rtt", qf.at_ms, {"median", "p99", "max"});
    std::size_t over_1ms = 0;
    for (double v : all) over_1ms += v > 1.0 ? 1 : 0;
    line("query_rtt_over_1ms_fraction", fixed(all.empty() ? 0.0 : static_cast<double>(over_1ms) / all.size(), 5));
    for (const auto& [k, n] : qf.errors) line("query_error_" + k, std::to_string(n));
    // Are the slow calls the ones made while a scan is in work (scheduled arrival to its
    // Correction)? Compare the share of slow calls started then with the share of time, for the
    // whole span and (with the breakdown) for its three phases: the scan's way into fuse-update
    // (ingest publishing, DDS fragments, decoding), the history RPC (fuse-state's lock), and
    // fuse-update's own work (state idle: only CPU is shared).
    struct Phase {
      std::string name;
      std::vector<std::pair<double, double>> spans;
      double seconds = 0.0;
      std::size_t slow = 0;
    };
    std::vector<Phase> phases;
    for (const char* name : {"scan", "transfer", "history", "update"}) {
      phases.emplace_back();
      phases.back().name = name;
    }
    for (const auto& [t_end, sc] : rec_.scans) {
      if (!sc.correction_wall) continue;
      phases[0].spans.emplace_back(sched(t_end), *sc.correction_wall);
      if (sc.first_request_wall && sc.ok_reply_wall) {
        phases[1].spans.emplace_back(sched(t_end), *sc.first_request_wall);
        phases[2].spans.emplace_back(*sc.first_request_wall, *sc.ok_reply_wall);
        phases[3].spans.emplace_back(*sc.ok_reply_wall, *sc.correction_wall);
      }
    }
    for (Phase& ph : phases) {
      for (const auto& [a, b] : ph.spans) ph.seconds += std::max(0.0, std::min(b, wall_to) - std::max(a, wall_from));
      for (double w : qf.slow_wall) {
        for (const auto& [a, b] : ph.spans) {
          if (w >= a && w < b) {
            ++ph.slow;
            break;
          }
        }
      }
    }
    line("query_slow_calls", std::to_string(qf.slow_wall.size()));
    const double window_s = wall_to - wall_from;
    for (const Phase& ph : phases) {
      if (ph.spans.empty()) continue;
      const std::string key = ph.name == "scan" ? "scan_in_work" : "scan_" + ph.name;
      line("query_slow_during_" + key + "_fraction",
           fixed(qf.slow_wall.empty() ? 0.0 : static_cast<double>(ph.slow) / qf.slow_wall.size(), 3));
      line(key + "_time_fraction", fixed(window_s > 0.0 ? ph.seconds / window_s : 0.0, 3));
    }
    for (const auto& [k, n] : qf.statuses) line("query_status_" + k, std::to_string(n));
    std::vector<double> idle_all = idle.latest_ms;
    idle_all.insert(idle_all.end(), idle.at_ms.begin(), idle.at_ms.end());
    std::size_t idle_errors = 0;
    for (const auto& [k, n] : idle.errors) idle_errors += n;
    line("query_idle_errors", std::to_string(idle_errors));
    print_stats("query_idle_rtt", idle_all, {"median", "p99", "max"});
  }
  {
    std::size_t expected = 0;
    for (double t : rec.imu_t) expected += in_window(t) ? 1 : 0;
    if (!rec.imu_t.empty()) line("odometry_expected", std::to_string(expected));
    print_stats("odometry_latency", rec_.odometry_ms, {"median", "p99", "max"});
  }
  std::vector<double> corr_ms, upd_ms, to_req_ms, rpc_ms, after_ms;
  std::size_t skipped = 0, updated = 0, prior_only = 0, not_ready = 0, traced = 0;
  for (const auto& [t_end, s] : rec_.scans) {
    if (!s.correction_wall) continue;
    if (s.result == fuse_msgs::SCAN_SKIPPED) {
      ++skipped;
      continue;
    }
    (s.result == fuse_msgs::SCAN_UPDATED ? updated : prior_only) += 1;
    corr_ms.push_back((*s.correction_wall - sched(t_end)) * 1e3);
    upd_ms.push_back(s.update_ms);
    if (s.first_request_wall && s.ok_reply_wall) {
      ++traced;
      to_req_ms.push_back((*s.first_request_wall - sched(t_end)) * 1e3);
      rpc_ms.push_back((*s.ok_reply_wall - *s.first_request_wall) * 1e3);
      after_ms.push_back((*s.correction_wall - *s.ok_reply_wall) * 1e3);
      not_ready += s.not_ready;
    }
  }
  {
    std::size_t expected = 0;
    for (double t : rec.scan_end) expected += in_window(t) ? 1 : 0;
    if (!rec.scan_end.empty()) line("scans_expected", std::to_string(expected));
  }
  line("corrections_updated", std::to_string(updated));
  line("corrections_prior_only", std::to_string(prior_only));
  line("corrections_skipped", std::to_string(skipped));
  print_stats("correction_latency", corr_ms, {"median", "p95", "max"});
  print_stats("update_ms", upd_ms, {"median", "p95", "max"});
  if (o.breakdown) {
    print_stats("imu_hop_latency", rec_.imu_hop_ms, {"median", "p99", "max"});
    line("scans_traced", std::to_string(traced));
    print_stats("scan_to_history_request", to_req_ms, {"median", "p95", "max"});
    print_stats("history_rpc", rpc_ms, {"median", "p95", "max"});
    line("history_not_ready_per_scan_mean", fixed(traced ? static_cast<double>(not_ready) / traced : 0.0, 2));
    print_stats("history_reply_to_correction", after_ms, {"median", "p95", "max"});
  }
  if (o.observe_scan) print_stats("scan_hop_latency", rec_.scan_hop_ms, {"median", "p95", "max"});
  if (!o.csv.empty()) {
    const auto rel = [&](const std::optional<double>& w) { return w ? fixed((*w - start_wall) * 1e3) : std::string(); };
    std::ofstream scans(o.csv + "-scans.csv");
    scans << "t_end,sched_ms,history_request_ms,history_ok_ms,correction_ms,result,update_ms,not_ready\n";
    for (const auto& [t_end, sc] : rec_.scans) {
      scans << fixed(t_end, 6) << ',' << fixed((sched(t_end) - start_wall) * 1e3) << ',' << rel(sc.first_request_wall) << ','
            << rel(sc.ok_reply_wall) << ',' << rel(sc.correction_wall) << ',' << sc.result << ',' << fixed(sc.update_ms)
            << ',' << sc.not_ready << '\n';
    }
    std::ofstream odo(o.csv + "-odometry.csv");
    odo << "t,latency_ms\n";
    for (std::size_t i = 0; i < rec_.odometry_t.size(); ++i) {
      odo << fixed(rec_.odometry_t[i], 6) << ',' << fixed(rec_.odometry_ms[i]) << '\n';
    }
    std::ofstream q(o.csv + "-queries.csv");
    q << "start_ms,kind,rtt_ms,ok\n";
    for (const auto& c : qf.log) {
      q << fixed((c.wall - start_wall) * 1e3) << ',' << (c.latest ? "latest" : "at") << ',' << fixed(c.ms, 4) << ','
        << (c.ok ? 1 : 0) << '\n';
    }
  }
  std::cout.flush();
  return interrupted ? 1 : 0;
}
