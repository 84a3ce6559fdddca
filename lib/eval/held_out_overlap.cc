#include "eval/held_out_overlap.h"

#include <limits>

#include <glog/logging.h>

namespace aqs {
namespace {

// Mean over `vertices` (all if empty) of |a_i - b_i|.
double MeanDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b,
                    const std::vector<int>& vertices) {
  CHECK_EQ(a.cols(), b.cols());
  if (vertices.empty()) return a.cols() > 0 ? (a - b).colwise().norm().mean() : 0.0;
  double sum = 0.0;
  for (const int v : vertices) sum += (a.col(v) - b.col(v)).norm();
  return sum / static_cast<double>(vertices.size());
}

}  // namespace

std::vector<HeldOutOverlap> FindHeldOutOverlaps(const Eigen::Matrix3Xd& neutral,
                                                const std::vector<Eigen::Matrix3Xd>& training,
                                                const std::vector<Eigen::Matrix3Xd>& held_out,
                                                const std::vector<int>& vertices,
                                                double fraction) {
  std::vector<HeldOutOverlap> overlaps;
  for (size_t t = 0; t < held_out.size(); ++t) {
    HeldOutOverlap overlap;
    overlap.test = static_cast<int>(t);
    overlap.motion = MeanDistance(held_out[t], neutral, vertices);
    if (!(overlap.motion > 0.0)) continue;
    overlap.distance = std::numeric_limits<double>::infinity();
    for (size_t p = 0; p < training.size(); ++p) {
      const double d = MeanDistance(held_out[t], training[p], vertices);
      if (d < overlap.distance) {
        overlap.distance = d;
        overlap.training = static_cast<int>(p);
      }
    }
    if (overlap.training >= 0 && overlap.distance < fraction * overlap.motion) {
      overlaps.push_back(overlap);
    }
  }
  return overlaps;
}

}  // namespace aqs
