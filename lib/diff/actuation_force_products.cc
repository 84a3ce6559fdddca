#include "diff/actuation_force_products.h"

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
  // Per element and direction, V (dP/dS [dS_e]) b_j at its vertex j: formed in parallel,
  // then scattered serially (cheap).
  std::vector<Eigen::Matrix<double, 3, 4>> nodal(static_cast<size_t>(num_elements) * k);
  const PolarCache* known = PolarCache::IfMatches(cache, x, a);
  ParallelFor(num_threads, 0, num_elements, [&](int, int e) {
    const ShapeTargetElement element = model.Element(x, a, e, known);
    const double volume = model.rest_shape(e).volume;
    for (int c = 0; c < k; ++c) {
      const Eigen::Matrix3d ds = SymmetricFromActuation(directions.col(c).data() + 6 * e);
      nodal[static_cast<size_t>(e) * k + c] =
          volume * element.StressActuationDirectional(ds) * model.gradient_weights(e);
    }
  });
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(pattern.num_dofs(), k);
  for (int e = 0; e < num_elements; ++e) {
    for (int j = 0; j < 4; ++j) {
      const int f = pattern.free_index(tets(j, e));
      if (f < 0) continue;
      for (int c = 0; c < k; ++c) {
        rhs.block<3, 1>(3 * f, c) -= nodal[static_cast<size_t>(e) * k + c].col(j);
      }
    }
  }
  return rhs;
}

}  // namespace aqs
