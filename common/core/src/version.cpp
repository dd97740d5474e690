#include "fuse/core/version.hpp"

namespace fuse {

const char* version() { return FUSE_VERSION_STRING; }

std::string version_line(const std::string& program) { return program + " (FUSE-SLAM) " + version(); }

}  // namespace fuse
