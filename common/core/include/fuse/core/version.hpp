// The release every binary reports with --version (the project version of CMakeLists.txt).
#pragma once

#include <string>

namespace fuse {

/// "0.3.0"
const char* version();

/// "NAME (FUSE-SLAM) 0.3.0": the first line of every --version.
std::string version_line(const std::string& program);

}  // namespace fuse
