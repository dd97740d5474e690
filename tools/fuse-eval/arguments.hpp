// Command line of fuse-eval.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"

namespace fuse::eval_tool {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Arguments {
  std::string gt_path;
  std::string est_path;
  eval::TrajectoryFormat format = eval::TrajectoryFormat::kTum;
  eval::EvaluationConfig config;  ///< association follows the format: KITTI matches by index
  bool json = false;
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

/// The --help text.
std::string usage();

}  // namespace fuse::eval_tool
