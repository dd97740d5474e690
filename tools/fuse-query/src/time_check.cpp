#include "time_check.hpp"

#include <cmath>

#include "fuse/query/client.hpp"

namespace fuse::query {

std::string check_query_time(double t) {
  if (!std::isfinite(t)) return "query time is not a finite number";
  if (t < 0.0) return "query time is negative";
  if (t > kMaxQueryTime) return "query time is beyond " + std::to_string(kMaxQueryTime) + " s";
  return {};
}

}  // namespace fuse::query
