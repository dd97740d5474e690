// The client's transport settings from a FUSE config file: the same `transport:` section the
// services read, with --set overrides applied, so the tool joins the services' domain.
#pragma once

#include <string>
#include <vector>

#include "fuse/query/client.hpp"

namespace fuse::query_tool {

/// Loads `file` (none: defaults), applies "dotted.key=value" overrides and reads its
/// `transport:` section (other sections are ignored). Throws fuse::ConfigError.
query::ClientOptions load_client_options(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace fuse::query_tool
