#include "diff/equilibrium_differentiator.h"

#include "diff/actuation_force_products.h"

#include <glog/logging.h>

#include "util/option_checks.h"
#include "util/parallel_for.h"
#include "util/wall_timer.h"

namespace aqs {

bool EquilibriumDifferentiatorOptions::Validate(std::string* error) const {
  std::string reuse_error;
  const bool reuse_ok = reuse.Validate(&reuse_error);
  return OptionChecks()
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Nested("reuse", reuse_ok, reuse_error)
      .Done(error);
}

namespace {

// Options the code built (CHECK: valid).
const EquilibriumDifferentiatorOptions& Checked(const EquilibriumDifferentiatorOptions& options) {
  std::string error;
  CHECK(options.Validate(&error)) << error;
  return options;
}

}  // namespace

EquilibriumDifferentiator::EquilibriumDifferentiator(
    const ShapeTargetModel& model, const std::vector<bool>& fixed_mask,
    const EquilibriumDifferentiatorOptions& options)
    : model_(model),
      options_(Checked(options)),
      owned_factorization_(
          std::make_unique<StiffnessFactorization>(model, fixed_mask, options.num_threads)),
      factorization_(owned_factorization_.get()) {}

EquilibriumDifferentiator::EquilibriumDifferentiator(
    StiffnessFactorization* factorization, const EquilibriumDifferentiatorOptions& options)
    : model_(factorization->model()), options_(Checked(options)), factorization_(factorization) {}

EquilibriumDifferentiator::~EquilibriumDifferentiator() = default;

bool EquilibriumDifferentiator::Prepare(const ShapeTargetModel::PositionsRef& x,
                                        const ShapeTargetModel::ActuationRef& a,
                                        std::string* error) {
  return PrepareAt(x, a, options_.reuse.max_iterations > 0, 0.0, error);
}

bool EquilibriumDifferentiator::PrepareShifted(const ShapeTargetModel::PositionsRef& x,
                                               const ShapeTargetModel::ActuationRef& a,
                                               double relative_shift, std::string* error) {
  CHECK_GT(relative_shift, 0.0);
  return PrepareAt(x, a, false, relative_shift, error);
}

bool EquilibriumDifferentiator::PrepareAt(const ShapeTargetModel::PositionsRef& x,
                                          const ShapeTargetModel::ActuationRef& a, bool defer,
                                          double relative_shift, std::string* error) {
  CHECK_EQ(x.cols(), model_.num_vertices());
  CHECK_EQ(a.cols(), model_.num_elements());
  prepared_ = false;
  timings_ = DifferentiationTimings();
  x_ = x;
  a_ = a;
  deferred_ = defer;
  factorization_->Assemble(x_, a_, StiffnessKind::kExact);
  if (deferred_) {
    timings_.assembly = factorization_->timings().assembly;
    generation_ = factorization_->generation();
    prepared_ = true;
    return true;
  }
  const bool ok = factorization_->FactorizeAssembled(relative_shift, error);
  generation_ = factorization_->generation();
  const FactorizationTimings& t = factorization_->timings();
  timings_.assembly = t.assembly;
  timings_.analysis = t.analysis;
  timings_.factorization = t.factorization;
  prepared_ = ok;
  return ok;
}

void EquilibriumDifferentiator::CheckPrepared() const {
  CHECK(prepared_) << "call Prepare() successfully first";
  CHECK_EQ(factorization_->generation(), generation_)
      << "the stiffness factorization changed since Prepare() (a solve on the shared "
         "factorization assembled or factorized another state): call Prepare() again";
}

Eigen::Matrix3Xd EquilibriumDifferentiator::SolveAdjoint(const Eigen::Matrix3Xd& dl_dx) {
  CheckPrepared();
  CHECK(dl_dx.cols() == model_.num_vertices())
      << "dL/dx has " << dl_dx.cols() << " columns, the model " << model_.num_vertices()
      << " vertices (one column per vertex)";
  CHECK(!deferred_) << "with options().reuse, use the overloads that return false on failure";
  Eigen::Matrix3Xd lambda = factorization_->Solve(dl_dx);
  timings_.solve = factorization_->timings().solve;
  return lambda;
}

bool EquilibriumDifferentiator::SolveAdjoint(const Eigen::Matrix3Xd& dl_dx, Eigen::Matrix3Xd* lambda,
                                             std::string* error) {
  CheckPrepared();
  CHECK(dl_dx.cols() == model_.num_vertices())
      << "dL/dx has " << dl_dx.cols() << " columns, the model " << model_.num_vertices()
      << " vertices (one column per vertex)";
  if (!deferred_) {
    *lambda = SolveAdjoint(dl_dx);
    return true;
  }
  Eigen::MatrixXd free;
  const int factorizations = factorization_->counters().factorizations;
  const bool solved = factorization_->SolveAssembled(factorization_->GatherFree(dl_dx),
                                                     options_.reuse, &free, error);
  // A factorization there was of the K Prepare assembled.
  generation_ = factorization_->generation();
  if (!solved) return false;
  if (factorization_->counters().factorizations > factorizations) {
    timings_.factorization = factorization_->timings().factorization;
  }
  timings_.solve = factorization_->timings().solve;
  *lambda = factorization_->ScatterFree(free.data());
  return true;
}

bool EquilibriumDifferentiator::LossGradient(const Eigen::Matrix3Xd& dl_dx, ActuationMatrix* gradient,
                                             std::string* error) {
  Eigen::Matrix3Xd lambda;
  if (!SolveAdjoint(dl_dx, &lambda, error)) return false;
  *gradient = GradientFromAdjoint(lambda);
  return true;
}

ActuationMatrix EquilibriumDifferentiator::LossGradient(const Eigen::Matrix3Xd& dl_dx) {
  return GradientFromAdjoint(SolveAdjoint(dl_dx));
}

const PolarCache* EquilibriumDifferentiator::CacheAtState() const {
  return PolarCache::IfMatches(&factorization_->polar_cache(), x_, a_);
}

ActuationMatrix EquilibriumDifferentiator::GradientFromAdjoint(const Eigen::Matrix3Xd& lambda) {
  WallTimer timer;
  const PolarCache* cache = CacheAtState();
  ActuationMatrix gradient(6, model_.num_elements());
  const Eigen::Matrix4Xi& tets = model_.tets();
  ParallelFor(options_.num_threads, 0, model_.num_elements(), [&](int, int e) {
    // dF_lambda = sum_k lambda_k b_k^T (lambda is zero on fixed vertices).
    const Eigen::Matrix3d df = aqs::DeformationGradient(
        model_.gradient_weights(e), lambda.col(tets(0, e)).data(),
        lambda.col(tets(1, e)).data(), lambda.col(tets(2, e)).data(),
        lambda.col(tets(3, e)).data());
    const ShapeTargetElement element = model_.Element(x_, a_, e, cache);
    gradient.col(e) = -model_.rest_shape(e).volume * element.StressActuationAdjoint(df);
  });
  timings_.accumulation = timer.Seconds();
  return gradient;
}

Eigen::MatrixXd EquilibriumDifferentiator::ActuationJacobianProduct(
    const Eigen::MatrixXd& directions) {
  CheckPrepared();
  CHECK(!deferred_) << "Jacobian products need Prepare without options().reuse";
  CHECK_EQ(directions.rows(), 6 * static_cast<Eigen::Index>(model_.num_elements()));
  const int k = static_cast<int>(directions.cols());
  WallTimer timer;
  const Eigen::MatrixXd rhs = ActuationForceProducts(model_, factorization_->pattern(), x_, a_,
                                                     directions, options_.num_threads,
                                                     CacheAtState());
  timings_.accumulation = timer.Seconds();
  const Eigen::MatrixXd dx_free = factorization_->SolveFree(rhs);
  timings_.solve = factorization_->timings().solve;
  Eigen::MatrixXd out(3 * static_cast<Eigen::Index>(model_.num_vertices()), k);
  for (int c = 0; c < k; ++c) {
    const Eigen::Matrix3Xd full = factorization_->ScatterFree(dx_free.col(c).data());
    out.col(c) = Eigen::Map<const Eigen::VectorXd>(full.data(), full.size());
  }
  return out;
}

}  // namespace aqs

namespace aqs {

Eigen::MatrixXd EquilibriumDifferentiator::FixedVertexJacobianProduct(const Eigen::MatrixXd& motion) {
  CheckPrepared();
  CHECK(!deferred_) << "Jacobian products need Prepare without options().reuse";
  CHECK(factorization_->energy_terms().empty())
      << "fixed-vertex products ignore energy terms; the system has some";
  const int n = model_.num_vertices();
  CHECK_EQ(motion.rows(), 3 * static_cast<Eigen::Index>(n));
  const int k = static_cast<int>(motion.cols());
  const StiffnessPattern& pattern = factorization_->pattern();
  const Eigen::Matrix4Xi& tets = model_.tets();
  WallTimer timer;
  const PolarCache* cache = CacheAtState();
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(pattern.num_dofs(), k);
  for (int e = 0; e < model_.num_elements(); ++e) {
    int fixed = 0;
    for (int j = 0; j < 4; ++j) fixed += pattern.free_index(tets(j, e)) < 0;
    if (fixed == 0 || fixed == 4) continue;
    const ShapeTargetElement element = model_.Element(x_, a_, e, cache);
    const Matrix9d h = element.StressDerivative();
    const Eigen::Matrix<double, 3, 4>& b = model_.gradient_weights(e);
    const double volume = model_.rest_shape(e).volume;
    for (int c = 0; c < k; ++c) {
      Eigen::Matrix3d df = Eigen::Matrix3d::Zero();
      for (int j = 0; j < 4; ++j) {
        const int v = tets(j, e);
        if (pattern.free_index(v) >= 0) continue;
        df += motion.block<3, 1>(3 * static_cast<Eigen::Index>(v), c) * b.col(j).transpose();
      }
      const Eigen::Matrix3d dp = UnvecRowMajor(h * VecRowMajor(df));
      for (int j = 0; j < 4; ++j) {
        const int f = pattern.free_index(tets(j, e));
        if (f >= 0) rhs.block<3, 1>(3 * f, c) -= volume * dp * b.col(j);
      }
    }
  }
  timings_.accumulation = timer.Seconds();
  const Eigen::MatrixXd dx_free = factorization_->SolveFree(rhs);
  timings_.solve = factorization_->timings().solve;
  Eigen::MatrixXd out = motion;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    out.block(3 * static_cast<Eigen::Index>(pattern.vertex_of_free(f)), 0, 3, k) =
        dx_free.block(3 * f, 0, 3, k);
  }
  return out;
}

bool PrepareExactOrShifted(EquilibriumDifferentiator* differentiator,
                           const ShapeTargetModel::PositionsRef& x,
                           const ShapeTargetModel::ActuationRef& a, double* shift,
                           std::string* error) {
  CHECK_LE(differentiator->options().reuse.max_iterations, 0) << "a deferred Prepare cannot fail";
  *shift = 0.0;
  if (differentiator->Prepare(x, a, error)) return true;
  for (double s = EquilibriumDifferentiator::kFirstRelativeShift;
       s <= EquilibriumDifferentiator::kLastRelativeShift; s *= 100.0) {
    std::string shift_error;
    if (differentiator->PrepareShifted(x, a, s, &shift_error)) {
      *shift = s;
      return true;
    }
  }
  return false;
}

}  // namespace aqs
