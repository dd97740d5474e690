// fuse-eval: evaluates an estimated trajectory against ground truth with evo's ATE / RPE
// definitions plus terminal drift (docs/evaluation-metrics.md). Prints "name: value" lines or
// one JSON object on stdout; any bad input gives a message on stderr and exit code 2. With
// --frame-of GT EST the estimate is put into the reference frame by another run's alignment (a
// run localized on a saved map, in the frame of the walk that made the map) and not aligned itself.
#include <exception>
#include <optional>
#include <iostream>
#include <string>

#include "arguments.hpp"
#include "fuse/eval/alignment.hpp"
#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 2;

int run(const fuse::eval_tool::Arguments& args) {
  const fuse::eval::Trajectory gt = fuse::eval::read_trajectory(args.gt_path, args.format);
  fuse::eval::Trajectory est = fuse::eval::read_trajectory(args.est_path, args.format);
  if (!args.frame_of.empty()) {
    // The other run's estimate -> reference transform, applied to this estimate as it is.
    fuse::eval::EvaluationConfig other = args.config;
    other.alignment = fuse::eval::AlignmentMode::kSE3;
    const fuse::eval::EvaluationResult frame =
        fuse::eval::evaluate(fuse::eval::read_trajectory(args.frame_of[0], args.format),
                             fuse::eval::read_trajectory(args.frame_of[1], args.format), other);
    est = fuse::eval::transform(est, frame.alignment);
  }
  const fuse::eval::EvaluationResult result = fuse::eval::evaluate(gt, est, args.config);
  std::cout << (args.json ? fuse::eval::format_json(result) : fuse::eval::format_text(result));
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  fuse::eval_tool::Arguments args;
  if (const std::optional<int> code = fuse::eval_tool::parse_arguments(argc, argv, args)) return *code;
  try {
    return run(args);
  } catch (const std::exception& e) {
    std::cerr << "fuse-eval: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "fuse-eval: unknown error\n";
  }
  return kExitBadInput;
}
