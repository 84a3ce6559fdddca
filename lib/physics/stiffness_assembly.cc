#include "physics/stiffness_assembly.h"

#include <glog/logging.h>

#include "physics/element_geometry.h"
#include "util/parallel_for.h"

namespace aqs {

void AssembleStiffness(const ShapeTargetModel& model, const StiffnessPattern& pattern,
                       const ShapeTargetModel::PositionsRef& x,
                       const ShapeTargetModel::ActuationRef& a, StiffnessKind kind,
                       int num_threads, std::vector<double>* values, const PolarCache* cache) {
  CHECK_EQ(pattern.num_vertices(), model.num_vertices());
  const size_t nnz = static_cast<size_t>(pattern.num_nonzeros());
  const int num_elements = model.num_elements();
  const int threads = ParallelForThreadCount(num_threads, num_elements);
  const PolarCache* known = PolarCache::IfMatches(cache, x, a);
  values->assign(nnz, 0.0);
  std::vector<std::vector<double>> extra(threads > 1 ? threads - 1 : 0,
                                         std::vector<double>(nnz, 0.0));
  ParallelForFixedOrder(threads, 0, num_elements, [&](int t, int e) {
    double* out = t == 0 ? values->data() : extra[t - 1].data();
    Eigen::Matrix<double, 9, 9> h;
    if (kind == StiffnessKind::kRotationFixed) {
      h = 2.0 * model.mu(e) * Eigen::Matrix<double, 9, 9>::Identity();
    } else {
      const ShapeTargetElement element = model.Element(x, a, e, known);
      h = kind == StiffnessKind::kExact ? element.StressDerivative()
                                        : element.ProjectedStressDerivative();
    }
    const Eigen::Matrix<double, 12, 12> ke =
        ElementHessian(h, model.gradient_weights(e), model.rest_shape(e).volume);
    for (int k = 0; k < 4; ++k) {
      for (int l = 0; l < 4; ++l) {
        if (pattern.BlockOffset(e, k, l, 0) < 0) continue;
        const bool diagonal = model.tets()(k, e) == model.tets()(l, e);
        for (int d = 0; d < 3; ++d) {
          double* column = out + pattern.BlockOffset(e, k, l, d);
          const int rows = diagonal ? d + 1 : 3;
          for (int c = 0; c < rows; ++c) column[c] += ke(3 * k + c, 3 * l + d);
        }
      }
    }
  });
  for (const std::vector<double>& part : extra) {
    double* out = values->data();
    for (size_t i = 0; i < nnz; ++i) out[i] += part[i];
  }
}

Eigen::MatrixXd DenseFromUpperCsc(const StiffnessPattern& pattern,
                                  const std::vector<double>& values) {
  const int n = pattern.num_dofs();
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  for (int j = 0; j < n; ++j) {
    for (int64_t p = pattern.column_starts()[j]; p < pattern.column_starts()[j + 1]; ++p) {
      const int i = static_cast<int>(pattern.row_indices()[p]);
      dense(i, j) = values[p];
      dense(j, i) = values[p];
    }
  }
  return dense;
}

}  // namespace aqs
