#include "topic_filter.hpp"

#include <fnmatch.h>

#include <stdexcept>

namespace fuse::record {
namespace {
bool matches(const std::string& pattern, const std::string& topic) {
  return fnmatch(pattern.c_str(), topic.c_str(), 0) == 0;
}
}  // namespace

TopicFilter::TopicFilter(const std::vector<std::string>& include, const std::vector<std::string>& exclude)
    : include_(include), exclude_(exclude) {
  for (const auto* list : {&include_, &exclude_}) {
    for (const auto& p : *list) {
      if (p.empty()) throw std::invalid_argument("empty topic pattern");
    }
  }
  if (include_.empty()) include_.push_back("*");
}

bool TopicFilter::accepts(const std::string& topic) const {
  bool in = false;
  for (const auto& p : include_) in = in || matches(p, topic);
  if (!in) return false;
  for (const auto& p : exclude_) {
    if (matches(p, topic)) return false;
  }
  return true;
}

std::vector<std::string> TopicFilter::unmatched(const std::vector<std::string>& topics) const {
  std::vector<std::string> out;
  for (const auto* list : {&include_, &exclude_}) {
    for (const auto& p : *list) {
      bool any = false;
      for (const auto& t : topics) any = any || matches(p, t);
      if (!any) out.push_back(p);
    }
  }
  return out;
}

std::vector<std::string> split_patterns(const std::string& list) {
  std::vector<std::string> out;
  if (list.empty()) return out;
  std::size_t start = 0;
  for (;;) {
    const auto comma = list.find(',', start);
    const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (item.empty()) throw std::invalid_argument("empty item in topic pattern list '" + list + "'");
    out.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

}  // namespace fuse::record
