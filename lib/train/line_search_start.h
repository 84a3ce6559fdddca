#ifndef AQS_TRAIN_LINE_SEARCH_START_H_
#define AQS_TRAIN_LINE_SEARCH_START_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// Where a line search's trial point lies on the line through two points evaluated
// before it: point = points[from] + t (points[to] - points[from]).
struct PointOnLine {
  int from = -1;
  int to = -1;
  double t = 0.0;
};

// A line search (Ceres' Wolfe or Armijo search along an L-BFGS direction) evaluates its
// trials x0 + alpha_k d on one line through the point it started from. Given earlier
// evaluated points (`points`, each of size n) and a new one (`point`, n values), finds
// two of them whose line holds `point`: the component of point - points[from] off the
// direction points[to] - points[from] below kRelativeTolerance times |point -
// points[from]|. Among such pairs it prefers a bracket (0 < t < 1) of the shortest
// span, else the pair whose nearer end is nearest to `point`; t stays in (0, kMaxT].
// Returns false if no pair holds the point, or the point repeats an earlier one.
// Costs O(n m^2) for m points. kPointOnLineMaxT is past Ceres' largest expansion of a
// step (max_line_search_step_expansion, 10 by default) with room for round-off: the
// caller judges the start it gives (by its force), not this function.
constexpr double kPointOnLineRelativeTolerance = 1e-8;
constexpr double kPointOnLineMaxT = 20.0;
bool FindPointOnLine(const std::vector<const Eigen::VectorXd*>& points, const double* point,
                     PointOnLine* line);

// The curved warm start of a pose's equilibrium at a line-search trial t (0 at `from`,
// 1 at `to`: the pose's equilibria, 3 x n, at the line's two evaluated ends). `last` is
// the end the solver's warm start came from and `start` that warm start (the end's
// first-order prediction of the trial's equilibrium). With E = last, O the other end
// and tau the trial's coordinate from O (0) to E (1) (tau = t where E is `to`, 1 - t
// where E is `from`), *candidate is the quadratic in tau through O with E's predicted
// step, E + tau (start - E) + (1 - tau)^2 (O - E): O at tau = 0, start at tau = 1.
// False (candidate untouched) where `last` is neither end.
bool CurvedLineStart(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to, double t,
                     const Eigen::Matrix3Xd& last, const Eigen::Matrix3Xd& start,
                     Eigen::Matrix3Xd* candidate);

}  // namespace aqs

#endif  // AQS_TRAIN_LINE_SEARCH_START_H_
