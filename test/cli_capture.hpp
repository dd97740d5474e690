// Runs a binary's argument parser on "NAME ARGS..." as main would, capturing what it printed.
#pragma once

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace fuse::test {

struct CapturedCli {
  std::optional<int> code;  ///< the parser's result: std::nullopt when the program would run
  std::string out, err;
};

/// parse(argc, argv) on {name, args...}, with stdout and stderr captured.
template <class Parse>
CapturedCli run_cli_parser(const std::string& name, std::vector<std::string> args, Parse parse) {
  args.insert(args.begin(), name);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  CapturedCli c;
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  c.code = parse(static_cast<int>(argv.size()), argv.data());
  c.out = ::testing::internal::GetCapturedStdout();
  c.err = ::testing::internal::GetCapturedStderr();
  return c;
}

}  // namespace fuse::test
