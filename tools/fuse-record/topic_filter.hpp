// Which topics fuse-record takes: glob patterns (fnmatch, '*' also matches '/') to include and
// to exclude, given as comma-separated lists on the command line.
#pragma once

#include <string>
#include <vector>

namespace fuse::record {

class TopicFilter {
 public:
  /// Empty `include` means every topic. Throws std::invalid_argument on an empty pattern.
  TopicFilter(const std::vector<std::string>& include, const std::vector<std::string>& exclude);
  bool accepts(const std::string& topic) const;
  /// Patterns that match none of `topics` (a typo the user should hear about).
  std::vector<std::string> unmatched(const std::vector<std::string>& topics) const;

 private:
  std::vector<std::string> include_, exclude_;
};

/// Splits "a,b,c" into its non-empty items; an empty item ("a,,b") is an error.
std::vector<std::string> split_patterns(const std::string& list);

}  // namespace fuse::record
