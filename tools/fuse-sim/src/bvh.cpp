#include "fuse/sim/bvh.hpp"

#include <algorithm>
#include <limits>

namespace fuse::sim {

namespace {
constexpr std::uint32_t kLeafSize = 4;  // primitives per leaf
}  // namespace

void Bvh::build(const std::vector<Eigen::Vector3d>& mins, const std::vector<Eigen::Vector3d>& maxs) {
  mins_ = mins;
  maxs_ = maxs;
  nodes_.clear();
  order_.resize(mins.size());
  for (std::uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
  if (!order_.empty()) build_node(0, static_cast<std::uint32_t>(order_.size()));
}

std::uint32_t Bvh::build_node(std::uint32_t begin, std::uint32_t end) {
  const std::uint32_t index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({});
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d clo = lo, chi = hi;  // centroid bounds
  for (std::uint32_t i = begin; i < end; ++i) {
    const std::uint32_t k = order_[i];
    lo = lo.cwiseMin(mins_[k]);
    hi = hi.cwiseMax(maxs_[k]);
    const Eigen::Vector3d c = 0.5 * (mins_[k] + maxs_[k]);
    clo = clo.cwiseMin(c);
    chi = chi.cwiseMax(c);
  }
  nodes_[index].min = lo;
  nodes_[index].max = hi;
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](std::uint32_t a, std::uint32_t b) {
                     return mins_[a][axis] + maxs_[a][axis] < mins_[b][axis] + maxs_[b][axis];
                   });
  build_node(begin, mid);  // left child is index + 1
  const std::uint32_t right = build_node(mid, end);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

}  // namespace fuse::sim
