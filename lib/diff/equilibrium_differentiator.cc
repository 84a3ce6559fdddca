#include "diff/equilibrium_differentiator.h"

#include <sstream>

#include <glog/logging.h>

#include "diff/stiffness_assembly.h"
#include "util/parallel_for.h"
#include "util/wall_timer.h"

namespace aqs {

EquilibriumDifferentiator::EquilibriumDifferentiator(
    const ShapeTargetModel& model, const std::vector<bool>& fixed_mask,
    const EquilibriumDifferentiatorOptions& options)
    : model_(model), options_(options), pattern_(model.tets(), fixed_mask) {
  CHECK_EQ(static_cast<int>(fixed_mask.size()), model.num_vertices());
  cholesky_ = std::make_unique<SparseCholesky>(pattern_.num_dofs(), &pattern_.column_starts(),
                                               &pattern_.row_indices());
}

EquilibriumDifferentiator::~EquilibriumDifferentiator() = default;

bool EquilibriumDifferentiator::Prepare(const ShapeTargetModel::PositionsRef& x, const ShapeTargetModel::ActuationRef& a,
                                        std::string* error) {
  CHECK_EQ(x.cols(), model_.num_vertices());
  CHECK_EQ(a.cols(), model_.num_elements());
  prepared_ = false;
  timings_ = DifferentiationTimings();
  if (pattern_.num_dofs() == 0) {
    *error = "every vertex is fixed: there is nothing to differentiate";
    return false;
  }
  x_ = x;
  a_ = a;
  WallTimer timer;
  AssembleStiffness(model_, pattern_, x_, a_, StiffnessKind::kExact, options_.num_threads,
                    &values_);
  timings_.assembly = timer.Seconds();
  const bool first = cholesky_->factor_nonzeros() == 0.0;
  std::string cholmod_error;
  const bool ok = cholesky_->Factorize(values_, &cholmod_error);
  if (first) timings_.analysis = cholesky_->analyze_seconds();
  timings_.factorization = cholesky_->factorize_seconds();
  if (!ok) {
    std::ostringstream out;
    out << "the stiffness K = d2E/dx2 cannot be factorized at this state: " << cholmod_error;
    const int column = cholesky_->failed_column();
    if (column >= 0) {
      out << "; that column is DOF " << "xyz"[column % 3] << " of vertex "
          << pattern_.vertex_of_free(column / 3)
          << ". K must be positive definite for implicit differentiation: the state may "
             "not be a stable equilibrium, or the fixed vertices may not prevent rigid "
             "motion";
    }
    *error = out.str();
    return false;
  }
  prepared_ = true;
  return true;
}

Eigen::VectorXd EquilibriumDifferentiator::GatherFree(const Eigen::Matrix3Xd& per_vertex) const {
  CHECK_EQ(per_vertex.cols(), model_.num_vertices());
  Eigen::VectorXd free(pattern_.num_dofs());
  for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
    free.segment<3>(3 * f) = per_vertex.col(pattern_.vertex_of_free(f));
  }
  return free;
}

Eigen::Matrix3Xd EquilibriumDifferentiator::ScatterFree(const double* free_values) const {
  Eigen::Matrix3Xd out = Eigen::Matrix3Xd::Zero(3, model_.num_vertices());
  for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
    out.col(pattern_.vertex_of_free(f)) = Eigen::Map<const Eigen::Vector3d>(free_values + 3 * f);
  }
  return out;
}

Eigen::Matrix3Xd EquilibriumDifferentiator::SolveAdjoint(const Eigen::Matrix3Xd& dl_dx) {
  CHECK(prepared_) << "call Prepare() successfully first";
  WallTimer timer;
  const Eigen::VectorXd lambda = cholesky_->Solve(GatherFree(dl_dx));
  timings_.solve = timer.Seconds();
  return ScatterFree(lambda.data());
}

ActuationMatrix EquilibriumDifferentiator::LossGradient(const Eigen::Matrix3Xd& dl_dx) {
  const Eigen::Matrix3Xd lambda = SolveAdjoint(dl_dx);
  WallTimer timer;
  ActuationMatrix gradient(6, model_.num_elements());
  const Eigen::Matrix4Xi& tets = model_.tets();
  ParallelFor(options_.num_threads, 0, model_.num_elements(), [&](int, int e) {
    // dF_lambda = sum_k lambda_k b_k^T (lambda is zero on fixed vertices).
    const Eigen::Matrix3d df = aqs::DeformationGradient(
        model_.gradient_weights(e), lambda.col(tets(0, e)).data(),
        lambda.col(tets(1, e)).data(), lambda.col(tets(2, e)).data(),
        lambda.col(tets(3, e)).data());
    const ShapeTargetElement element = model_.Element(x_, a_, e);
    gradient.col(e) = -model_.rest_shape(e).volume * element.StressActuationAdjoint(df);
  });
  timings_.accumulation = timer.Seconds();
  return gradient;
}

Eigen::MatrixXd EquilibriumDifferentiator::ActuationJacobianProduct(
    const Eigen::MatrixXd& directions) {
  CHECK(prepared_) << "call Prepare() successfully first";
  CHECK_EQ(directions.rows(), 6 * static_cast<Eigen::Index>(model_.num_elements()));
  const int k = static_cast<int>(directions.cols());
  const int num_elements = model_.num_elements();
  const Eigen::Matrix4Xi& tets = model_.tets();
  WallTimer timer;
  // B v for every direction: per element, V (dP/dS [dS_e]) b_j at its vertex j. The
  // element terms are formed in parallel, then scattered serially (cheap).
  std::vector<Eigen::Matrix<double, 3, 4>> nodal(static_cast<size_t>(num_elements) * k);
  ParallelFor(options_.num_threads, 0, num_elements, [&](int, int e) {
    const ShapeTargetElement element = model_.Element(x_, a_, e);
    const double volume = model_.rest_shape(e).volume;
    for (int c = 0; c < k; ++c) {
      const Eigen::Matrix3d ds = SymmetricFromActuation(directions.col(c).data() + 6 * e);
      nodal[static_cast<size_t>(e) * k + c] =
          volume * element.StressActuationDirectional(ds) * model_.gradient_weights(e);
    }
  });
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(pattern_.num_dofs(), k);
  for (int e = 0; e < num_elements; ++e) {
    for (int j = 0; j < 4; ++j) {
      const int f = pattern_.free_index(tets(j, e));
      if (f < 0) continue;
      for (int c = 0; c < k; ++c) {
        rhs.block<3, 1>(3 * f, c) -= nodal[static_cast<size_t>(e) * k + c].col(j);
      }
    }
  }
  timings_.accumulation = timer.Seconds();
  timer.Reset();
  const Eigen::MatrixXd dx_free = cholesky_->Solve(rhs);
  timings_.solve = timer.Seconds();
  Eigen::MatrixXd out(3 * static_cast<Eigen::Index>(model_.num_vertices()), k);
  for (int c = 0; c < k; ++c) {
    const Eigen::Matrix3Xd full = ScatterFree(dx_free.col(c).data());
    out.col(c) = Eigen::Map<const Eigen::VectorXd>(full.data(), full.size());
  }
  return out;
}

}  // namespace aqs
