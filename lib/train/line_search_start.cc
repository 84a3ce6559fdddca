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
  std::vector<double> distance(m, 0.0);  // |point - points[i]|
  for (int i = 0; i < m; ++i) {
    if (points[i]->size() != n) continue;
    distance[i] = (x - *points[i]).norm();
    if (distance[i] == 0.0) return false;  // an earlier point again: its states are exact
  }
  bool found = false, found_bracket = false;
  double best_score = std::numeric_limits<double>::infinity();
  // Offers the pair in one orientation: point = points[from] + t (points[to] - points[from]).
  auto offer = [&](int from, int to, double t, double span, double off_line) {
    if (!(t > 0.0) || t > kPointOnLineMaxT) return;
    if (!(off_line <= kPointOnLineRelativeTolerance * distance[from])) return;
    const bool bracket = t < 1.0;
    // A bracket: its span; otherwise the distance from the nearer end, points[to].
    const double score = bracket ? span : (t - 1.0) * span;
    if ((bracket && !found_bracket) || (bracket == found_bracket && score < best_score)) {
      *line = PointOnLine{from, to, t};
      best_score = score;
      found = true;
      found_bracket = found_bracket || bracket;
    }
  };
  // Each pair once; its line's distance from the point does not depend on the orientation.
  for (int i = 0; i < m; ++i) {
    if (points[i]->size() != n) continue;
    for (int j = i + 1; j < m; ++j) {
      if (points[j]->size() != n) continue;
      const Eigen::VectorXd direction = *points[j] - *points[i];
      const double length2 = direction.squaredNorm();
      if (!(length2 > 0.0)) continue;
      const double t = (x - *points[i]).dot(direction) / length2;
      const double off_line = (x - *points[i] - t * direction).norm();
      const double span = std::sqrt(length2);
      offer(i, j, t, span, off_line);
      offer(j, i, 1.0 - t, span, off_line);
    }
  }
  return found;
}

bool CurvedLineStart(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to, double t,
                     const Eigen::Matrix3Xd& last, const Eigen::Matrix3Xd& start,
                     Eigen::Matrix3Xd* candidate) {
  const auto same = [&](const Eigen::Matrix3Xd& end) {
    return last.cols() == end.cols() && (end.array() == last.array()).all();
  };
  const bool last_is_to = same(to);
  if (!last_is_to && !same(from)) return false;
  const Eigen::Matrix3Xd& e = last_is_to ? to : from;
  const Eigen::Matrix3Xd& o = last_is_to ? from : to;
  const double tau = last_is_to ? t : 1.0 - t;
  *candidate = e + tau * (start - e) + (1.0 - tau) * (1.0 - tau) * (o - e);
  return true;
}

}  // namespace aqs
