#ifndef AQS_FIT_FIT_EQUILIBRIUM_H_
#define AQS_FIT_FIT_EQUILIBRIUM_H_

// Internal to lib/fit: included by the LatentFitter's own .cc files only.

#include <mutex>
#include <vector>

#include <ceres/evaluation_callback.h>
#include <Eigen/Core>
#include <glog/logging.h>

#include "fit/latent_fit.h"
#include "util/wall_timer.h"

namespace aqs {

// The largest actuation entry a fit's trial point may ask for (io/actuation_io.h's
// kMaxActuationStretch): beyond, the step counts as unsuccessful.
constexpr double kMaxFitActuationEntry = 1e3;

// The work the fit's residuals share, at one point of the parameters (z, then 6 numbers
// per fitted bone): the decoded actuation, the equilibrium x* (solved warm from the
// equilibrium of the last accepted point), and with Jacobians the actuation Jacobian
// da/dz and the differentiator prepared at x*.
//
// As Ceres' EvaluationCallback (Fit) it does this work before each evaluation, and it
// moves the warm start to a point only when Ceres asks for Jacobians there, which a
// trust-region minimizer does only at accepted points; FitCost::Evaluate is then a read
// of it. With a non-convex energy the branch a solve lands on depends on its start, so
// rejected trial points never become starts. Without the callback (a cost from
// NewCostFunction, e.g. under a gradient checker) the cost prepares points on demand and
// the warm start never moves: each evaluation is a function of its parameters alone.
class LatentFitter::FitEquilibrium final : public ceres::EvaluationCallback {
 public:
  struct Point {
    Eigen::VectorXd key;  // all parameter blocks, concatenated
    bool solved = false;  // the equilibrium was reached
    bool decoded = false;
    bool differentiated = false;  // da_dz computed and the differentiator prepared at state
    ActuationMatrix a;
    Eigen::MatrixXd da_dz;  // (6 num_elements) x latent_dim
    Eigen::Matrix3Xd state;
    // dx*/dz (3 num_vertices x latent_dim) and dx*/d(bone b's 6 parameters), computed
    // once at a differentiated point and shared by the fit's residual blocks (empty:
    // not yet).
    Eigen::MatrixXd dx_dz;
    std::vector<Eigen::MatrixXd> dx_dbone;
  };

  FitEquilibrium(LatentFitter* fitter, bool fit_bones) : fitter_(fitter), fit_bones_(fit_bones) {
    block_sizes_.push_back(fitter->model_.latent_dim());
    if (fit_bones_) block_sizes_.resize(1 + fitter->model_.bones.size(), 6);
    for (int size : block_sizes_) parameter_count_ += size;
  }

  const std::vector<int>& block_sizes() const { return block_sizes_; }

  // The parameter blocks Ceres updates in place (sizes as block_sizes()), read by
  // PrepareForEvaluation.
  void set_blocks(std::vector<double*> blocks) {
    CHECK_EQ(blocks.size(), block_sizes_.size());
    blocks_ = std::move(blocks);
  }

  void PrepareForEvaluation(bool evaluate_jacobians, bool /*new_evaluation_point*/) override {
    CHECK_EQ(blocks_.size(), block_sizes_.size()) << "set_blocks before solving";
    const Point* point = Prepare(blocks_.data(), evaluate_jacobians);
    if (evaluate_jacobians && point != nullptr) fitter_->accepted_state_ = point->state;
  }

  // The point at `parameters` (one array per block), prepared if it is not the last one
  // prepared: decoded and solved, and with `jacobians` differentiated. nullptr if its
  // equilibrium was not reached, its actuations are absurd, or the stiffness there
  // cannot be factorized (Ceres then treats the step as unsuccessful).
  const Point* Prepare(double const* const* parameters, bool jacobians) {
    Eigen::VectorXd key(parameter_count_);
    for (size_t b = 0, offset = 0; b < block_sizes_.size(); offset += block_sizes_[b], ++b) {
      key.segment(offset, block_sizes_[b]) =
          Eigen::Map<const Eigen::VectorXd>(parameters[b], block_sizes_[b]);
    }
    const ActiveModel& model = fitter_->model_;
    if (!(point_.key.size() == key.size() && point_.key == key)) {
      point_ = Point();
      point_.key = key;
      std::vector<RigidTransform> bones = fitter_->bones_;
      if (fit_bones_) {
        for (size_t b = 0; b < bones.size(); ++b) {
          bones[b] = BoneTransformFromParameters(parameters[1 + b]);
        }
      }
      Decode(jacobians);
      // A trial latent far outside the training latents (absurd actuations): an
      // unsuccessful step, not a long solve after absurd targets.
      if (!(point_.a.cwiseAbs().maxCoeff() <= kMaxFitActuationEntry)) return nullptr;
      QuasistaticSolver& solver = *fitter_->solver_;
      solver.SetPositions(fitter_->accepted_state_);
      solver.SetFixedPositions(ModelBoundaryConditions(model, bones).positions);
      solver.actuation() = point_.a;
      WallTimer timer;
      const QuasistaticSolveReport report = solver.Solve();
      fitter_->stats_.solves += 1;
      fitter_->stats_.solve_factorizations += report.factorizations;
      fitter_->stats_.solve_seconds += timer.Seconds();
      if (!report.converged) {
        failure_ = "the equilibrium was not reached: " + report.Summary();
        return nullptr;
      }
      point_.solved = true;
      point_.state = solver.positions();
    }
    if (!point_.solved) return nullptr;
    if (!point_.decoded || (jacobians && point_.da_dz.size() == 0)) Decode(jacobians);
    if (jacobians && !point_.differentiated) {
      WallTimer timer;
      fitter_->stats_.jacobians += 1;
      std::string error;
      // Where the exact K is singular or barely not positive definite (a free mesh piece
      // without surface, which models prepared before 2026-12-07 keep: its block is
      // singular at every state), the regularized K, as training's adjoint does.
      double shift = 0.0;
      const bool prepared = PrepareExactOrShifted(fitter_->differentiator_.get(), point_.state,
                                                  point_.a, &shift, &error);
      fitter_->stats_.jacobian_seconds += timer.Seconds();
      if (!prepared) {
        failure_ = "the stiffness cannot be factorized at the equilibrium: " + error;
        return nullptr;
      }
      if (shift > 0.0) fitter_->stats_.shifted_jacobians += 1;
      point_.differentiated = true;
    }
    return &point_;
  }

  // dx*/dz at the last point prepared, which must be differentiated (cached). Thread-safe
  // between Prepares: Ceres evaluates the residual blocks of one point in parallel, and
  // the data blocks of a fit (a scan and its landmarks) share this object.
  // Why the last point that could not be prepared failed ("" : none failed): an
  // equilibrium not reached, or a stiffness that cannot be factorized (absurd actuations
  // say nothing: an unsuccessful trial step).
  const std::string& failure() const { return failure_; }

  const Eigen::MatrixXd& LatentProduct() {
    CHECK(point_.differentiated);
    std::lock_guard<std::mutex> hold(products_mutex_);
    if (point_.dx_dz.size() == 0) {
      point_.dx_dz = fitter_->differentiator_->ActuationJacobianProduct(point_.da_dz);
    }
    return point_.dx_dz;
  }

  // dx*/d(bone b's 6 parameters: rotation vector, translation) at the last point
  // prepared, which must be differentiated (cached): the motion of the bone's fixed
  // vertices, carried through the equilibrium. Thread-safe as LatentProduct.
  const Eigen::MatrixXd& BoneProduct(size_t b) {
    CHECK(point_.differentiated);
    const ActiveModel& model = fitter_->model_;
    std::lock_guard<std::mutex> hold(products_mutex_);
    point_.dx_dbone.resize(model.bones.size());
    if (point_.dx_dbone[b].size() == 0) {
      const Eigen::Index rows = 3 * static_cast<Eigen::Index>(point_.state.cols());
      Eigen::MatrixXd motion = Eigen::MatrixXd::Zero(rows, 6);
      const double* parameters = point_.key.data() + model.latent_dim() + 6 * b;
      for (int v : model.bones[b].vertices) {
        motion.block<3, 3>(3 * static_cast<Eigen::Index>(v), 0) =
            RotatedPointJacobian(parameters, model.mesh.vertices.col(v));
        motion.block<3, 3>(3 * static_cast<Eigen::Index>(v), 3) = Eigen::Matrix3d::Identity();
      }
      point_.dx_dbone[b] = fitter_->differentiator_->FixedVertexJacobianProduct(motion);
    }
    return point_.dx_dbone[b];
  }

  // Seeds the last point: `state` is the equilibrium at parameters `key` (all blocks,
  // concatenated), so that preparing it solves nothing.
  void Seed(const Eigen::VectorXd& key, const Eigen::Matrix3Xd& state) {
    CHECK_EQ(key.size(), parameter_count_);
    point_ = Point();
    point_.key = key;
    point_.solved = true;
    point_.state = state;
  }

  // The equilibrium at `key` if it is the last point prepared and was reached, else nullptr.
  const Eigen::Matrix3Xd* StateAt(const Eigen::VectorXd& key) const {
    return point_.solved && point_.key.size() == key.size() && point_.key == key ? &point_.state
                                                                                  : nullptr;
  }

 private:
  void Decode(bool jacobian) {
    const ActiveModel& model = fitter_->model_;
    const Eigen::Map<const Eigen::VectorXd> z(point_.key.data(), model.latent_dim());
    if (jacobian) {
      point_.da_dz = model.decoder->ActuationJacobian(model.decoder_params.data(), z, &point_.a);
    } else {
      DecoderWorkspace workspace;
      model.decoder->Decode(model.decoder_params.data(), z, &point_.a, &workspace);
    }
    point_.decoded = true;
  }

  LatentFitter* fitter_;
  bool fit_bones_;
  std::vector<int> block_sizes_;
  int parameter_count_ = 0;
  std::vector<double*> blocks_;
  Point point_;
  std::string failure_;
  std::mutex products_mutex_;  // the lazy fills of point_'s products
};

}  // namespace aqs

#endif  // AQS_FIT_FIT_EQUILIBRIUM_H_
