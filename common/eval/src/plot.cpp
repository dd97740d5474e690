// Evaluation figures drawn by gnuplot from data files (fuse/eval/plot.hpp).
#include "fuse/eval/plot.hpp"

#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "fuse/eval/metrics.hpp"

extern char** environ;

namespace fuse::eval {
namespace {

namespace fs = std::filesystem;

constexpr int kDataPrecision = 6;

std::string decimals(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

/// A gnuplot single-quoted string: a quote inside is written twice.
std::string quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text) out += (c == '\'' ? std::string("''") : std::string(1, c));
  return out + "'";
}

std::ofstream open_data(const fs::path& path, const std::string& columns) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path.string());
  f << "# " << columns << '\n' << std::fixed << std::setprecision(kDataPrecision);
  return f;
}

void check_written(std::ofstream& f, const fs::path& path) {
  f.flush();
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

void write_trajectory(const fs::path& path, const ErrorSeries& s) {
  std::ofstream f = open_data(path, "t distance_m ref_x ref_y ref_z est_x est_y est_z");
  for (std::size_t i = 0; i < s.reference.size(); ++i) {
    const Eigen::Vector3d& r = s.reference[i].p;
    const Eigen::Vector3d& e = s.aligned[i].p;
    f << s.reference[i].t << ' ' << s.distance_m[i] << ' ' << r.x() << ' ' << r.y() << ' ' << r.z() << ' '
      << e.x() << ' ' << e.y() << ' ' << e.z() << '\n';
  }
  check_written(f, path);
}

void write_ape(const fs::path& path, const ErrorSeries& s) {
  std::ofstream f = open_data(path, "distance_m t ape_translation_m ape_rotation_deg");
  for (std::size_t i = 0; i < s.ape_m.size(); ++i) {
    f << s.distance_m[i] << ' ' << s.reference[i].t << ' ' << s.ape_m[i] << ' ' << s.ape_deg[i] << '\n';
  }
  check_written(f, path);
}

void write_rpe(const fs::path& path, const ErrorSeries& s) {
  std::ofstream f = open_data(path, "distance_m t rpe_translation_m rpe_rotation_deg (at each pair's end)");
  for (std::size_t k = 0; k < s.rpe_pairs.size(); ++k) {
    const std::size_t j = s.rpe_pairs[k].second;
    f << s.distance_m[j] << ' ' << s.reference[j].t << ' ' << s.rpe_m[k] << ' ' << s.rpe_deg[k] << '\n';
  }
  check_written(f, path);
}

void write_scan_time(const fs::path& path, const ScanTimes& times) {
  std::ofstream f = open_data(path, "time_since_first_scan_s scan_time_ms");
  for (std::size_t i = 0; i < times.t.size(); ++i) f << times.t[i] - times.t.front() << ' ' << times.total_ms[i] << '\n';
  check_written(f, path);
}

/// Two stacked panels, translation (column 3) and rotation (column 4) over distance (column 1).
void error_figure(std::ostream& gp, const fs::path& data, const fs::path& svg, const std::string& title,
                  const std::string& what, const ErrorStatistics& m, const ErrorStatistics& deg) {
  gp << "set output " << quoted(svg.string()) << "\n"
     << "set multiplot layout 2,1 title " << quoted(title) << "\n"
     << "set xlabel 'distance travelled (m)'\nset ylabel 'translation error (m)'\n"
     << "plot " << quoted(data.string()) << " using 1:3 with lines lw 1.5 lc rgb '#1f77b4' title "
     << quoted(what + " translation: RMSE " + decimals(m.rmse, 4) + " m, max " + decimals(m.max, 4) + " m") << "\n"
     << "set ylabel 'rotation error (deg)'\n"
     << "plot " << quoted(data.string()) << " using 1:4 with lines lw 1.5 lc rgb '#d62728' title "
     << quoted(what + " rotation: RMSE " + decimals(deg.rmse, 3) + "°, max " + decimals(deg.max, 3) + "°") << "\n"
     << "unset multiplot\n";
}

/// "set xrange/yrange" of one square box holding every position of both trajectories, so that a
/// top view drawn at equal scale (size ratio -1) fills the figure whatever the path's shape.
std::string square_ranges(const ErrorSeries& s) {
  Eigen::Vector2d lo = s.reference.front().p.head<2>(), hi = lo;
  for (const Trajectory* trajectory : {&s.reference, &s.aligned}) {
    for (const StampedPose& pose : *trajectory) {
      lo = lo.cwiseMin(pose.p.head<2>());
      hi = hi.cwiseMax(pose.p.head<2>());
    }
  }
  constexpr double kMargin = 1.05;    // room around the path
  constexpr double kMinSpanM = 1.0;   // a path shorter than this is shown in a 1 m box
  const double half = 0.5 * kMargin * std::max((hi - lo).maxCoeff(), kMinSpanM);
  const Eigen::Vector2d c = 0.5 * (lo + hi);
  std::ostringstream out;
  out << "set xrange [" << c.x() - half << ':' << c.x() + half << "]\nset yrange [" << c.y() - half << ':'
      << c.y() + half << "]\n";
  return out.str();
}

/// Runs `program script`, waiting for it; throws naming the program unless it exits 0.
void run_gnuplot(const std::string& program, const fs::path& script) {
  std::vector<std::string> args{program, script.string()};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int error = posix_spawnp(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ);
  if (error != 0) {
    throw std::runtime_error("cannot run " + program + " (" + std::strerror(error) +
                             "); install gnuplot (Debian package gnuplot-nox) to draw plots");
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waiting for " + program + ": " + std::strerror(errno));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error(program + " failed on " + script.string() +
                             (WIFEXITED(status) ? " (exit code " + std::to_string(WEXITSTATUS(status)) + ")"
                                                : " (killed by a signal)"));
  }
}

}  // namespace

std::vector<std::string> write_plots(const std::string& dir_name, const ErrorSeries& series, const ScanTimes* times,
                                     const PlotConfig& config) {
  if (series.reference.empty() || series.reference.size() != series.aligned.size() ||
      series.ape_m.size() != series.reference.size() || series.rpe_m.size() != series.rpe_pairs.size()) {
    throw std::invalid_argument("write_plots: the error series are empty or of unequal length");
  }
  std::error_code ec;
  fs::create_directories(dir_name, ec);
  if (ec) throw std::runtime_error("cannot create plot directory " + dir_name + ": " + ec.message());
  const fs::path dir = fs::absolute(dir_name);
  const std::string name = config.title.empty() ? std::string() : " (" + config.title + ")";

  write_trajectory(dir / "trajectory.dat", series);
  write_ape(dir / "ape.dat", series);
  const bool with_rpe = !series.rpe_pairs.empty();
  if (with_rpe) write_rpe(dir / "rpe.dat", series);
  const bool with_times = times != nullptr && !times->t.empty();
  if (with_times) write_scan_time(dir / "scan_time.dat", *times);

  std::vector<std::string> figures;
  const fs::path script = dir / "plots.gp";
  std::ofstream gp(script);
  if (!gp) throw std::runtime_error("cannot write " + script.string());
  const std::string traj = quoted((dir / "trajectory.dat").string());
  gp << "# Written by fuse-eval --plot; run again with: gnuplot plots.gp\n"
     << "set terminal svg size 960,640 dynamic enhanced font 'sans,12' background rgb 'white'\n"
     << "set encoding utf8\nset grid\nset key top left box opaque\n";

  figures.push_back((dir / "trajectory_top.svg").string());
  gp << "set output " << quoted(figures.back()) << "\n"
     << "set title " << quoted("Top view: estimate (aligned) and reference" + name) << "\n"
     << "set xlabel 'x (m)'\nset ylabel 'y (m)'\nset size ratio -1\n" << square_ranges(series)
     << "plot " << traj << " using 3:4 with lines lw 3 lc rgb '#9a9a9a' title 'reference', "
     << traj << " using 6:7 with lines lw 1.5 lc rgb '#d62728' title 'estimate'\n"
     << "set size noratio\nset autoscale xy\n";

  figures.push_back((dir / "trajectory_side.svg").string());
  gp << "set output " << quoted(figures.back()) << "\n"
     << "set title " << quoted("Side view: estimate (aligned) and reference" + name) << "\n"
     << "set xlabel 'x (m)'\nset ylabel 'z (m)'\n"
     << "plot " << traj << " using 3:5 with lines lw 3 lc rgb '#9a9a9a' title 'reference', "
     << traj << " using 6:8 with lines lw 1.5 lc rgb '#d62728' title 'estimate'\n";
  gp << "unset title\n";

  figures.push_back((dir / "ape.svg").string());
  error_figure(gp, dir / "ape.dat", figures.back(), "Absolute pose error (after alignment)" + name, "APE",
               compute_statistics(series.ape_m), compute_statistics(series.ape_deg));
  if (with_rpe) {
    figures.push_back((dir / "rpe.svg").string());
    error_figure(gp, dir / "rpe.dat", figures.back(),
                 "Relative pose error over " + decimals(config.rpe_delta_m, 2) + " m of path" + name, "RPE",
                 compute_statistics(series.rpe_m), compute_statistics(series.rpe_deg));
  }
  if (with_times) {
    const TimeStatistics st = time_statistics(times->total_ms);
    figures.push_back((dir / "scan_time.svg").string());
    gp << "set output " << quoted(figures.back()) << "\n"
       << "set title " << quoted("Per-scan time" + name) << "\n"
       << "set key top right\n"
       << "set xlabel 'time since the first scan (s)'\nset ylabel 'scan time (ms)'\n"
       << "plot " << quoted((dir / "scan_time.dat").string()) << " using 1:2 with lines lw 1 lc rgb '#1f77b4' title "
       << quoted("per scan: mean " + decimals(st.mean_ms, 2) + " / P95 " + decimals(st.p95_ms, 2) + " / max " +
                 decimals(st.max_ms, 2) + " ms")
       << ", " << st.mean_ms << " with lines dt 2 lw 1.5 lc rgb '#2ca02c' title 'mean', " << st.p95_ms
       << " with lines dt 3 lw 1.5 lc rgb '#ff7f0e' title 'P95'\n";
  }
  gp << "set output\n";
  gp.flush();
  if (!gp) throw std::runtime_error("cannot write " + script.string());
  gp.close();

  run_gnuplot(config.gnuplot, script);
  for (const std::string& figure : figures) {
    if (!fs::exists(figure) || fs::file_size(figure) == 0) throw std::runtime_error("gnuplot did not draw " + figure);
  }
  return figures;
}

}  // namespace fuse::eval
