#include "train/line_search_start.h"

#include <cmath>
#include <limits>

namespace aqs {

bool FindPointOnLine(const std::vector<const Eigen::VectorXd*>& points, const double* point,
                     PointOnLine* line) {
  const int m = static_cast<int>(points.size());
  if (m < 2) return false;
  const Eigen::Index n = points[0]->size();
  const Eigen::Map<const Eigen::VectorXd> x(point, n);
  bool found = false, found_bracket = false;
  double best_score = std::numeric_limits<double>::infinity();
  for (int i = 0; i < m; ++i) {
    const Eigen::VectorXd offset = x - *points[i];
    const double offset_norm = offset.norm();
    if (offset_norm == 0.0) return false;  // an earlier point again: its states are exact
    for (int j = 0; j < m; ++j) {
      if (j == i || points[j]->size() != n) continue;
      const Eigen::VectorXd direction = *points[j] - *points[i];
      const double length2 = direction.squaredNorm();
      if (!(length2 > 0.0)) continue;
      const double t = offset.dot(direction) / length2;
      if (!(t > 0.0) || t > kPointOnLineMaxT) continue;
      const double off_line = (offset - t * direction).norm();
      if (!(off_line <= kPointOnLineRelativeTolerance * offset_norm)) continue;
      const bool bracket = t < 1.0;
      // A bracket: its span; otherwise the distance from the nearer end, points[to].
      const double span = std::sqrt(length2);
      const double score = bracket ? span : (t - 1.0) * span;
      if ((bracket && !found_bracket) || (bracket == found_bracket && score < best_score)) {
        *line = PointOnLine{i, j, t};
        best_score = score;
        found = true;
        found_bracket = found_bracket || bracket;
      }
    }
  }
  return found;
}

}  // namespace aqs
