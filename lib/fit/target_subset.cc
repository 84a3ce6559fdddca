#include "fit/target_subset.h"

#include <algorithm>
#include <limits>
#include <vector>

#include <glog/logging.h>

namespace aqs {

FitTarget FarthestPointSubset(const FitTarget& target, int count) {
  CHECK_GE(count, 1);
  const int k = target.num_points();
  const bool weighted = target.weights.size() > 0;
  std::vector<int> usable;
  for (int i = 0; i < k; ++i) {
    if (!weighted || target.weights[i] > 0) usable.push_back(i);
  }
  std::vector<int> chosen;
  if (static_cast<int>(usable.size()) <= count) {
    chosen = usable;
  } else {
    // distance[j]: from usable point j to the nearest chosen point.
    std::vector<double> distance(usable.size(), std::numeric_limits<double>::infinity());
    int next = 0;
    for (int c = 0; c < count; ++c) {
      chosen.push_back(usable[next]);
      const Eigen::Vector3d added = target.positions.col(usable[next]);
      int farthest = 0;
      double farthest_distance = -1.0;
      for (size_t j = 0; j < usable.size(); ++j) {
        const double to_added = (target.positions.col(usable[j]) - added).squaredNorm();
        distance[j] = std::min(distance[j], to_added);
        if (distance[j] > farthest_distance) {
          farthest_distance = distance[j];
          farthest = static_cast<int>(j);
        }
      }
      next = farthest;
    }
  }
  const int n = static_cast<int>(chosen.size());
  FitTarget subset;
  subset.vertices.resize(3, n);
  subset.barycentric.resize(3, n);
  subset.positions.resize(3, n);
  if (weighted) subset.weights.resize(n);
  if (target.normals.cols() > 0) subset.normals.resize(3, n);
  subset.tangential_weight = target.tangential_weight;
  for (int i = 0; i < n; ++i) {
    const int p = chosen[i];
    subset.vertices.col(i) = target.vertices.col(p);
    subset.barycentric.col(i) = target.barycentric.col(p);
    subset.positions.col(i) = target.positions.col(p);
    if (weighted) subset.weights[i] = target.weights[p];
    if (target.normals.cols() > 0) subset.normals.col(i) = target.normals.col(p);
  }
  return subset;
}

}  // namespace aqs
