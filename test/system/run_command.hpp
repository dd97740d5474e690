// Runs a shell command with its stderr merged into its stdout; returns its exit code (-1 when it
// could not run or did not exit) and appends what it printed to `output`.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace fuse {

inline int run_command(const std::string& command, std::string& output) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  char buf[4096];
  while (std::fgets(buf, sizeof(buf), pipe) != nullptr) output += buf;
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace fuse
