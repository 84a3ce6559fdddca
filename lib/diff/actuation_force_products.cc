#include "diff/actuation_force_products.h"

#include <algorithm>
#include <vector>

#include <glog/logging.h>

#include "util/parallel_for.h"

namespace aqs {

Eigen::MatrixXd ActuationForceProducts(const ShapeTargetModel& model,
                                       const StiffnessPattern& pattern,
                                       const ShapeTargetModel::PositionsRef& x,
                                       const ShapeTargetModel::ActuationRef& a,
                                       const Eigen::MatrixXd& directions, int num_threads,
                                       const PolarCache* cache) {
  const int num_elements = model.num_elements();
  CHECK_EQ(directions.rows(), 6 * static_cast<Eigen::Index>(num_elements));
  const int k = static_cast<int>(directions.cols());
  const Eigen::Matrix4Xi& tets = model.tets();
  // Per element and direction, V (dP/dS [dS_e]) b_j at its vertex j: formed in parallel
  // for a block of kBlockElements elements at a time, then scattered serially (cheap), so
  // that the buffer stays small (for all elements at once it was twice the size of
  // `directions`: 0.38 GB at 250K elements and 16 directions).
  constexpr int kBlockElements = 16384;
  std::vector<Eigen::Matrix<double, 3, 4>> nodal(
      static_cast<size_t>(std::min(num_elements, kBlockElements)) * k);
  const PolarCache* known = PolarCache::IfMatches(cache, x, a);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(pattern.num_dofs(), k);
  for (int first = 0; first < num_elements; first += kBlockElements) {
    const int last = std::min(num_elements, first + kBlockElements);
    ParallelFor(num_threads, first, last, [&](int, int e) {
      const ShapeTargetElement element = model.Element(x, a, e, known);
      const double volume = model.rest_shape(e).volume;
      for (int c = 0; c < k; ++c) {
        const Eigen::Matrix3d ds = SymmetricFromActuation(directions.col(c).data() + 6 * e);
        nodal[static_cast<size_t>(e - first) * k + c] =
            volume * element.StressActuationDirectional(ds) * model.gradient_weights(e);
      }
    });
    for (int e = first; e < last; ++e) {
      for (int j = 0; j < 4; ++j) {
        const int f = pattern.free_index(tets(j, e));
        if (f < 0) continue;
        for (int c = 0; c < k; ++c) {
          rhs.block<3, 1>(3 * f, c) -= nodal[static_cast<size_t>(e - first) * k + c].col(j);
        }
      }
    }
  }
  return rhs;
}

}  // namespace aqs
