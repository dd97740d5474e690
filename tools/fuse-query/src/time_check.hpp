// Client-side validation of a query time: a request that cannot be answered is not sent.
#pragma once

#include <string>

namespace fuse::query {

/// Empty when t can be asked for; otherwise why not (non-finite, negative, beyond kMaxQueryTime).
std::string check_query_time(double t);

}  // namespace fuse::query
