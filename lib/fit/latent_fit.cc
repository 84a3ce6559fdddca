#include "fit/latent_fit.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include <ceres/cost_function.h>
#include <ceres/covariance.h>
#include <ceres/evaluation_callback.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Geometry>
#include <glog/logging.h>

#include "fit/gaussian_prior_cost.h"
#include "fit/latent_prior.h"
#include "fit/target_subset.h"
#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"
#include "util/wall_timer.h"

namespace aqs {

namespace {

// The largest actuation entry a fit's trial point may ask for (io/actuation_io.h's
// kMaxActuationStretch): beyond, the step counts as unsuccessful.
constexpr double kMaxFitActuationEntry = 1e3;

// Each scan point matched to the closest point of `surface` (triangles of the
// neutral), with robust weights: the target of one matching round.
FitTarget MatchPointCloud(const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& surface,
                          const Eigen::Matrix3Xi& triangles, const PointCloudFitOptions& options,
                          int num_threads, int* used, double* mean_distance) {
  const TriangleBvh bvh(surface, triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, num_threads);
  FitTarget target;
  const Eigen::Index m = points.cols();
  target.vertices.resize(3, m);
  target.barycentric.resize(3, m);
  target.positions = points;
  target.weights.resize(m);
  if (options.tangential_weight < 1.0) {
    target.normals.resize(3, m);
    target.tangential_weight = std::max(options.tangential_weight, 0.0);
  }
  *used = 0;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const ClosestPointResult& c = closest[i];
    target.vertices.col(i) = triangles.col(c.triangle);
    target.barycentric.col(i) = c.barycentric;
    if (target.normals.cols() == m) {
      const Eigen::Vector3i t = triangles.col(c.triangle);
      const Eigen::Vector3d n = (surface.col(t[1]) - surface.col(t[0]))
                                    .cross(surface.col(t[2]) - surface.col(t[0]));
      const double length = n.norm();
      target.normals.col(i) = length > 0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
    }
    double w = 1.0;
    if (options.max_distance > 0 && c.distance > options.max_distance) w = 0.0;
    if (w > 0 && options.robust_scale > 0) {
      const double r = c.distance / options.robust_scale;
      w = 1.0 / (1.0 + r * r);
    }
    target.weights[i] = w;
    if (w > 0) {
      ++*used;
      sum += c.distance;
    }
  }
  *mean_distance = *used > 0 ? sum / *used : 0.0;
  return target;
}

}  // namespace

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
      if (!report.converged) return nullptr;
      point_.solved = true;
      point_.state = solver.positions();
    }
    if (!point_.solved) return nullptr;
    if (!point_.decoded || (jacobians && point_.da_dz.size() == 0)) Decode(jacobians);
    if (jacobians && !point_.differentiated) {
      WallTimer timer;
      fitter_->stats_.jacobians += 1;
      std::string error;
      const bool prepared = fitter_->differentiator_->Prepare(point_.state, point_.a, &error);
      fitter_->stats_.jacobian_seconds += timer.Seconds();
      if (!prepared) return nullptr;
      point_.differentiated = true;
    }
    return &point_;
  }

  // dx*/dz at the last point prepared, which must be differentiated (cached).
  const Eigen::MatrixXd& LatentProduct() {
    CHECK(point_.differentiated);
    if (point_.dx_dz.size() == 0) {
      point_.dx_dz = fitter_->differentiator_->ActuationJacobianProduct(point_.da_dz);
    }
    return point_.dx_dz;
  }

  // dx*/d(bone b's 6 parameters: rotation vector, translation) at the last point
  // prepared, which must be differentiated (cached): the motion of the bone's fixed
  // vertices, carried through the equilibrium.
  const Eigen::MatrixXd& BoneProduct(size_t b) {
    CHECK(point_.differentiated);
    const ActiveModel& model = fitter_->model_;
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
};

// Residuals sqrt(w_k / sum w) (p_k(x*) - y_k) (3 K) over the blocks z and, if fitted,
// one 6-number block per bone, at the equilibrium FitEquilibrium prepares (shared, or
// owned when there is no evaluation callback).
class LatentFitter::FitCost final : public ceres::CostFunction {
  struct Stencil;  // below

 public:
  // A point cloud without correspondence: one residual per scan point, its robust
  // distance to the simulated surface, re-matched (closest points) at every evaluation:
  //   r_i = sqrt(1/M) R(d_i),  R(d) = d / sqrt(1 + (d/s)^2)  (s = robust_scale; R(d) = d
  // for s <= 0), d_i the distance signed by the side of the matched triangle, clamped
  // to +-max_distance (beyond it the residual is constant). The derivative of a
  // closest-point distance is u^T dp (u the unit direction from the scan point to its
  // closest point, signed likewise; the closest point's sliding is second order), so
  // dr_i = sqrt(1/M) R'(d_i) u_i^T dp_i, exact wherever the matching is unique.
  FitCost(LatentFitter* fitter, FitEquilibrium* equilibrium, const Eigen::Matrix3Xd& cloud,
          const PointCloudFitOptions& options)
      : fitter_(fitter), equilibrium_(equilibrium), target_(&own_target_), cloud_(&cloud),
        cloud_options_(options) {
    CHECK_GT(cloud.cols(), 0);
    set_num_residuals(static_cast<int>(cloud.cols()));
    *mutable_parameter_block_sizes() = equilibrium->block_sizes();
  }

  FitCost(LatentFitter* fitter, FitEquilibrium* equilibrium, const FitTarget& target)
      : fitter_(fitter), equilibrium_(equilibrium), target_(&target) {
    const ActiveModel& model = fitter->model_;
    const int k = target.num_points();
    set_num_residuals(3 * k);
    *mutable_parameter_block_sizes() = equilibrium->block_sizes();
    double total = 0.0;
    for (int i = 0; i < k; ++i) total += target.weights.size() > 0 ? target.weights[i] : 1.0;
    CHECK_GT(total, 0.0) << "fit targets need a positive total weight";
    // Each target point as a combination of 12 state vertices plus a constant offset.
    stencils_.resize(k);
    for (int i = 0; i < k; ++i) {
      Stencil& s = stencils_[i];
      const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
      s.scale = std::sqrt(w / total);
      s.projector = s.scale * Eigen::Matrix3d::Identity();
      if (target.normals.cols() == k) {
        const Eigen::Vector3d n = target.normals.col(i);
        const Eigen::Matrix3d nn = n * n.transpose();
        s.projector = s.scale * (nn + target.tangential_weight * (Eigen::Matrix3d::Identity() - nn));
      }
      for (int c = 0; c < 3; ++c) {
        const int v = target.vertices(c, i);
        CHECK(v >= 0 && v < model.num_surface_vertices()) << "target vertex " << v;
      }
      SetSurfaceStencil(model, target.vertices.col(i), target.barycentric.col(i), &s);
    }
  }

  // A cost with its own FitEquilibrium (no evaluation callback: NewCostFunction).
  void Own(std::unique_ptr<FitEquilibrium> equilibrium) { own_equilibrium_ = std::move(equilibrium); }

  // Cloud mode: matches the scan to the surface of state x; sets the stencils of the
  // matched points, the residuals and the gradient rows (R'(d) u / sqrt(M), 3 x M).
  void MatchCloud(const Eigen::Matrix3Xd& x, double* residuals, std::vector<Stencil>* stencils,
                  Eigen::Matrix3Xd* cloud_rows) const {
    const ActiveModel& model = fitter_->model_;
    const Eigen::Matrix3Xd surface = EmbeddedPositions(model.embedding, model.mesh.tets, x);
    const Eigen::Matrix3Xi& triangles = model.neutral.triangles;
    const TriangleBvh bvh(surface, triangles);
    const std::vector<ClosestPointResult> closest =
        bvh.ClosestPoints(*cloud_, fitter_->options_.num_threads);
    const Eigen::Index m = cloud_->cols();
    const double scale = 1.0 / std::sqrt(static_cast<double>(m));
    const double s = cloud_options_.robust_scale;
    const double cap = cloud_options_.max_distance;
    stencils->resize(m);
    cloud_rows->resize(3, m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const ClosestPointResult& c = closest[i];
      Stencil& st = (*stencils)[i];
      const Eigen::Vector3i t = triangles.col(c.triangle);
      SetSurfaceStencil(model, t, c.barycentric, &st);
      // Signed by the side of the triangle: sigma = sign(v . n) |v|, v = p - y, whose
      // gradient sign(v . n) v / |v| is n itself for a closest point inside a triangle,
      // so the residual is smooth where the surface passes through a scan point.
      Eigen::Vector3d n =
          (surface.col(t[1]) - surface.col(t[0])).cross(surface.col(t[2]) - surface.col(t[0]));
      const double length = n.norm();
      n = length > 0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d v = c.point - cloud_->col(i);
      double d = c.distance;
      Eigen::Vector3d u = d > 1e-12 ? Eigen::Vector3d(v / d) : n;
      if (u.dot(n) < 0) {
        u = -u;
        d = -d;
      }
      bool clamped = false;
      if (cap > 0 && std::abs(d) > cap) {
        d = d > 0 ? cap : -cap;
        clamped = true;
      }
      double value = d, slope = 1.0;
      if (s > 0) {
        const double q = 1.0 + (d / s) * (d / s);
        value = d / std::sqrt(q);
        slope = 1.0 / (q * std::sqrt(q));
      }
      residuals[i] = scale * value;
      cloud_rows->col(i) = clamped ? Eigen::Vector3d::Zero() : Eigen::Vector3d(scale * slope * u);
    }
  }

  // A read of the point FitEquilibrium prepared (it prepares it here only when there is
  // no evaluation callback, see there).
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const bool want_z = jacobians != nullptr && jacobians[0] != nullptr;
    bool want_bones = false;
    for (size_t b = 1; jacobians != nullptr && b < parameter_block_sizes().size(); ++b) {
      want_bones |= jacobians[b] != nullptr;
    }
    const FitEquilibrium::Point* point = equilibrium_->Prepare(parameters, want_z || want_bones);
    if (point == nullptr) return false;  // Ceres treats the step as unsuccessful
    const Eigen::Matrix3Xd& x = point->state;
    const std::vector<Stencil>* stencils = &stencils_;
    std::vector<Stencil> matched;
    Eigen::Matrix3Xd cloud_rows;
    if (cloud_ != nullptr) {
      MatchCloud(x, residuals, &matched, &cloud_rows);
      stencils = &matched;
    } else {
      const int k = target_->num_points();
      for (int i = 0; i < k; ++i) {
        const Stencil& s = stencils_[i];
        Eigen::Vector3d p = s.offset;
        for (int j = 0; j < 12; ++j) p += s.weight[j] * x.col(s.vertex[j]);
        Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = s.projector * (p - target_->positions.col(i));
      }
    }
    if (!want_z && !want_bones) return true;
    if (want_z) FillJacobian(equilibrium_->LatentProduct(), *stencils, cloud_rows, jacobians[0]);
    for (size_t b = 0; b + 1 < parameter_block_sizes().size(); ++b) {
      if (jacobians[1 + b] == nullptr) continue;
      FillJacobian(equilibrium_->BoneProduct(b), *stencils, cloud_rows, jacobians[1 + b]);
    }
    return true;
  }

 private:
  struct Stencil {
    int vertex[12];
    double weight[12];
    Eigen::Vector3d offset;
    double scale;
    Eigen::Matrix3d projector;  // scale * P_k (identity scaled for point-to-point)
  };

  // The vertex, weight and offset entries of *s for the surface point sum_c
  // barycentric(c) * (embedded surface vertex vertices(c)): the three embedding
  // stencils, scaled (entries 4 c .. 4 c + 3 for corner c).
  static void SetSurfaceStencil(const ActiveModel& model, const Eigen::Vector3i& vertices,
                                const Eigen::Vector3d& barycentric, Stencil* s) {
    s->offset.setZero();
    for (int c = 0; c < 3; ++c) {
      const PointStencil point = EmbeddingStencil(model.embedding, model.mesh.tets, vertices[c]);
      s->offset += barycentric[c] * point.offset;
      for (int j = 0; j < 4; ++j) {
        s->vertex[4 * c + j] = point.vertex[j];
        s->weight[4 * c + j] = barycentric[c] * point.weight[j];
      }
    }
  }

  // Row-major (3K x columns; cloud mode M x columns) Jacobian of the residuals from dx
  // (3 num_vertices x columns), through the points' stencils (and cloud mode's rows).
  void FillJacobian(const Eigen::MatrixXd& dx, const std::vector<Stencil>& stencils,
                    const Eigen::Matrix3Xd& cloud_rows, double* out) const {
    const Eigen::Index columns = dx.cols();
    if (cloud_ != nullptr) {  // one row per scan point: g_i^T dp_i
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
          out, cloud_->cols(), columns);
      for (Eigen::Index i = 0; i < cloud_->cols(); ++i) {
        const Stencil& s = stencils[i];
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(columns);
        if (cloud_rows.col(i).squaredNorm() > 0) {
          for (int j = 0; j < 12; ++j) {
            if (s.weight[j] != 0.0) {
              row += s.weight[j] * (cloud_rows.col(i).transpose() *
                                    dx.middleRows(3 * static_cast<Eigen::Index>(s.vertex[j]), 3));
            }
          }
        }
        jac.row(i) = row;
      }
      return;
    }
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
        out, 3 * target_->num_points(), columns);
    for (int i = 0; i < target_->num_points(); ++i) {
      const Stencil& s = stencils[i];
      Eigen::MatrixXd dp = Eigen::MatrixXd::Zero(3, columns);
      for (int j = 0; j < 12; ++j) {
        if (s.weight[j] != 0.0) dp += s.weight[j] * dx.middleRows(3 * static_cast<Eigen::Index>(s.vertex[j]), 3);
      }
      jac.middleRows(3 * i, 3) = s.projector * dp;
    }
  }

  LatentFitter* fitter_;
  FitEquilibrium* equilibrium_;
  std::unique_ptr<FitEquilibrium> own_equilibrium_;
  FitTarget own_target_;  // empty: cloud mode
  const FitTarget* target_;
  const Eigen::Matrix3Xd* cloud_ = nullptr;
  PointCloudFitOptions cloud_options_;
  // Per target point (fixed targets; cloud mode matches at every evaluation).
  std::vector<Stencil> stencils_;
};

LatentFitter::LatentFitter(const ActiveModel& model, const LatentFitOptions& options)
    : model_(model), options_(options), bones_(RestBoneTransforms(model)),
      accepted_state_(model.mesh.vertices) {
  CHECK(model.decoder) << "latent fitting needs a trained model";
  prior_ = model.fit_prior.empty() ? LearnFitPrior(model) : model.fit_prior;
  CHECK_EQ(prior_.latent.size(), model.latent_dim());
  CHECK_EQ(prior_.bones.size(), model.bones.size());
  physics_ = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = options.num_threads;
  solver_ = std::make_unique<QuasistaticSolver>(*physics_, ModelBoundaryConditions(model, bones_),
                                                solver_options);
  differentiator_ = std::make_unique<EquilibriumDifferentiator>(
      solver_->stiffness_factorization(), EquilibriumDifferentiatorOptions{options.num_threads});
}

LatentFitter::~LatentFitter() = default;

void LatentFitter::set_bone_transforms(const std::vector<RigidTransform>& transforms) {
  CHECK_EQ(transforms.size(), model_.bones.size());
  bones_ = transforms;
  solver_->SetFixedPositions(ModelBoundaryConditions(model_, bones_).positions);
}

void LatentFitter::ForgetFactor() { solver_->stiffness_factorization()->RequestRefresh(); }

double LatentFitter::FactorNonzeros() {
  StiffnessFactorization* factorization = solver_->stiffness_factorization();
  if (factorization->cholesky().factor_nonzeros() == 0) factorization->Analyze();
  return factorization->cholesky().factor_nonzeros();
}

Eigen::VectorXd LatentFitter::MeanLatent() const { return model_.latents.rowwise().mean(); }

ceres::CostFunction* LatentFitter::NewCostFunction(const FitTarget& target) {
  auto equilibrium = std::make_unique<FitEquilibrium>(this, options_.fit_bones && !model_.bones.empty());
  auto* cost = new FitCost(this, equilibrium.get(), target);
  cost->Own(std::move(equilibrium));
  return cost;
}

ceres::CostFunction* LatentFitter::NewCloudCostFunction(const Eigen::Matrix3Xd& points,
                                                       const PointCloudFitOptions& options) {
  auto equilibrium = std::make_unique<FitEquilibrium>(this, options_.fit_bones && !model_.bones.empty());
  auto* cost = new FitCost(this, equilibrium.get(), points, options);
  cost->Own(std::move(equilibrium));
  return cost;
}

void LatentFitter::set_start_state(const Eigen::Matrix3Xd& state) {
  CHECK_EQ(state.cols(), model_.mesh.num_vertices());
  accepted_state_ = state;
}

void LatentFitter::StartFromTrainingPose(int p) {
  CHECK(p >= 0 && p < model_.num_poses());
  if (p < static_cast<int>(model_.states.size()) &&
      model_.states[p].cols() == model_.mesh.num_vertices()) {
    set_start_state(model_.states[p]);
  }
}

bool LatentFitter::Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state,
                            Eigen::Matrix3Xd* surface, std::string* error) {
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model_.decoder->Decode(model_.decoder_params.data(), z, &a, &workspace);
  solver_->SetPositions(accepted_state_);
  solver_->SetFixedPositions(ModelBoundaryConditions(model_, bones_).positions);
  solver_->actuation() = a;
  WallTimer timer;
  QuasistaticSolveReport report = solver_->Solve();
  stats_.solves += 1;
  stats_.solve_factorizations += report.factorizations;
  if (!report.converged) {  // once more from rest
    solver_->SetPositions(model_.mesh.vertices);
    report = solver_->Solve();
    stats_.solves += 1;
    stats_.solve_factorizations += report.factorizations;
  }
  last_simulate_report_ = report;
  stats_.solve_seconds += timer.Seconds();
  if (!report.converged) {
    *error = "the equilibrium was not reached: " + report.Summary();
    *state = solver_->positions();
    *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
    return false;
  }
  *state = solver_->positions();
  accepted_state_ = *state;
  *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
  return true;
}

void AddFitCounters(const LatentFitResult& other, LatentFitResult* result) {
  result->iterations += other.iterations;
  result->solves += other.solves;
  result->solve_factorizations += other.solve_factorizations;
  result->solve_seconds += other.solve_seconds;
  result->jacobians += other.jacobians;
  result->jacobian_seconds += other.jacobian_seconds;
}

bool LatentFitter::Fit(const FitTarget& target, const Eigen::VectorXd& initial,
                       LatentFitResult* result, std::string* error) {
  const int coarse = options_.coarse_points;
  if (direct_cloud_ != nullptr || coarse <= 0 || target.num_points() <= 2 * coarse ||
      target.normals.cols() > 0) {
    return FitFrom(target, initial, result, error);
  }
  const std::vector<RigidTransform> start_bones = bones_;
  const Eigen::Matrix3Xd start_state = accepted_state_;
  if (!FitFrom(target, initial, result, error)) return false;
  const LatentFitResult direct = *result;
  const double direct_objective = Objective(target, direct.surface, direct.latent);
  // The second start: the same start, a sparse subset of the points, then all of them.
  bones_ = start_bones;
  accepted_state_ = start_state;
  LatentFitResult sparse, fine;
  std::string second_error;
  const bool second_ok =
      FitFrom(FarthestPointSubset(target, coarse), initial, &sparse, &second_error) &&
      !sparse.failed && FitFrom(target, sparse.latent, &fine, &second_error) && !fine.failed;
  const bool second_better =
      second_ok && Objective(target, fine.surface, fine.latent) < direct_objective;
  *result = second_better ? fine : direct;
  // The counters of every fit that ran (a failed second start counts what it did).
  AddFitCounters(second_better ? direct : fine, result);
  AddFitCounters(sparse, result);
  result->second_start_ran = true;
  result->second_start_kept = second_better;
  bones_ = result->bones;
  accepted_state_ = result->state;
  return true;
}

bool LatentFitter::FitFrom(const FitTarget& target, const Eigen::VectorXd& initial,
                           LatentFitResult* result, std::string* error) {
  const int d = model_.latent_dim();
  CHECK_EQ(initial.size(), d);
  CHECK_EQ(target.vertices.cols(), target.positions.cols());
  CHECK_EQ(target.barycentric.cols(), target.positions.cols());
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  stats_ = LatentFitResult();
  if (!Simulate(z, &state, &surface, error)) {
    *error = "at the initial latent: " + *error;
    result->latent = z;
    result->bones = bones_;
    result->state = state;
    result->surface = surface;
    return false;
  }
  const bool fit_bones = options_.fit_bones && !model_.bones.empty();
  std::vector<Eigen::Matrix<double, 6, 1>> bone_parameters(model_.bones.size());
  for (size_t b = 0; b < model_.bones.size(); ++b) {
    BoneTransformToParameters(bones_[b], bone_parameters[b].data());
  }
  std::vector<double*> blocks = {z.data()};
  if (fit_bones) {
    for (auto& p : bone_parameters) blocks.push_back(p.data());
  }
  // Solves and differentiates before Ceres evaluates the residuals (see FitEquilibrium).
  FitEquilibrium equilibrium(this, fit_bones);
  equilibrium.set_blocks(blocks);
  ceres::Problem::Options problem_options;
  problem_options.evaluation_callback = &equilibrium;
  ceres::Problem problem(problem_options);
  double total_weight = 0.0;
  // W of the data residuals' scaling 1/sqrt(W) (FitCost), for the noise estimate.
  const double data_weight = direct_cloud_ != nullptr ? static_cast<double>(direct_cloud_->cols())
                                                      : TotalWeight(target);
  FitCost* data_cost = nullptr;
  if (direct_cloud_ != nullptr) {
    data_cost = new FitCost(this, &equilibrium, *direct_cloud_, *cloud_options_);
    total_weight = static_cast<double>(direct_cloud_->cols());
    if (options_.prior_points_cap > 0) total_weight = std::min(total_weight, options_.prior_points_cap);
  } else {
    data_cost = new FitCost(this, &equilibrium, target);
    total_weight = PriorPoints(target, options_.prior_points_cap);
  }
  // The data's residual blocks (the priors' come after): what the noise is estimated from.
  std::vector<ceres::ResidualBlockId> data_blocks = {
      problem.AddResidualBlock(data_cost, nullptr, blocks)};
  if (cloud_options_ != nullptr && cloud_options_->landmarks.num_points() > 0 &&
      cloud_options_->landmark_weight > 0) {
    // The scan's landmarks: their mean squared distance, times the weight.
    data_blocks.push_back(problem.AddResidualBlock(
        new FitCost(this, &equilibrium, cloud_options_->landmarks),
        new ceres::ScaledLoss(nullptr, cloud_options_->landmark_weight, ceres::TAKE_OWNERSHIP),
        blocks));
  }
  // The parameters, all blocks concatenated (FitEquilibrium's key).
  auto key = [&]() {
    Eigen::VectorXd k(z.size() + (fit_bones ? 6 * static_cast<Eigen::Index>(bone_parameters.size()) : 0));
    k.head(z.size()) = z;
    for (size_t b = 0; fit_bones && b < bone_parameters.size(); ++b) {
      k.segment(z.size() + 6 * static_cast<Eigen::Index>(b), 6) = bone_parameters[b];
    }
    return k;
  };
  equilibrium.Seed(key(), state);  // the start's equilibrium is known
  if (options_.latent_regularization > 0) {
    problem.AddResidualBlock(new LatentPrior(d, options_.latent_regularization), nullptr, z.data());
  }
  if (options_.latent_prior > 0) {
    problem.AddResidualBlock(new GaussianPriorCost(prior_.latent.mean, prior_.latent.whitening,
                                                   options_.latent_prior / total_weight),
                             nullptr, z.data());
  }
  // Scans weigh the bone prior by their own weight and centre it on the bones their fit
  // started from (PointCloudFitOptions::bone_prior).
  const bool scan = cloud_options_ != nullptr;
  const double bone_prior = scan && cloud_options_->bone_prior >= 0 ? cloud_options_->bone_prior
                                                                    : options_.bone_prior;
  if (fit_bones && bone_prior > 0) {
    for (size_t b = 0; b < model_.bones.size(); ++b) {
      const Eigen::VectorXd centre =
          scan ? Eigen::VectorXd(cloud_bone_centres_[b]) : prior_.bones[b].mean;
      problem.AddResidualBlock(new GaussianPriorCost(centre, prior_.bones[b].whitening,
                                                     bone_prior / total_weight),
                               nullptr, bone_parameters[b].data());
    }
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.function_tolerance = options_.function_tolerance;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = options_.parameter_tolerance;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (fit_bones) {
    for (size_t b = 0; b < model_.bones.size(); ++b) {
      bones_[b] = BoneTransformFromParameters(bone_parameters[b].data());
    }
  }
  // The final point's equilibrium: the last evaluation's when that was the final point
  // (Ceres ends on an accepted point), else solved again.
  bool simulated = true;
  if (const Eigen::Matrix3Xd* known = equilibrium.StateAt(key())) {
    state = *known;
    accepted_state_ = state;
    surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, state);
  } else {
    simulated = Simulate(z, &state, &surface, error);
  }
  result->latent = z;
  result->bones = bones_;
  result->state = state;
  result->surface = surface;
  if (!simulated) return false;
  result->parameter_covariance.resize(0, 0);
  result->surface_std.resize(0);
  result->noise_sigma = 0.0;
  result->uncertainty_message.clear();
  if (options_.uncertainty && summary.termination_type != ceres::FAILURE) {
    EstimateUncertainty(&problem, blocks, data_blocks, data_weight, &equilibrium, result);
  }
  const int k = target.num_points();
  Eigen::VectorXd distance(k);
  int used = 0;
  double sum = 0, sum_squares = 0, worst = 0;
  for (int i = 0; i < k; ++i) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int c = 0; c < 3; ++c) p += target.barycentric(c, i) * surface.col(target.vertices(c, i));
    distance[i] = (p - target.positions.col(i)).norm();
    if (target.weights.size() > 0 && target.weights[i] <= 0) continue;
    ++used;
    sum += distance[i];
    sum_squares += distance[i] * distance[i];
    worst = std::max(worst, distance[i]);
  }
  result->used_points = used;
  result->mean_error = used > 0 ? sum / used : 0.0;
  result->rms_error = used > 0 ? std::sqrt(sum_squares / used) : 0.0;
  result->max_error = worst;
  result->iterations = static_cast<int>(summary.iterations.size()) - 1;
  result->solves = stats_.solves;
  result->solve_factorizations = stats_.solve_factorizations;
  result->solve_seconds = stats_.solve_seconds;
  result->jacobians = stats_.jacobians;
  result->jacobian_seconds = stats_.jacobian_seconds;
  result->converged = summary.termination_type == ceres::CONVERGENCE;
  result->failed = summary.termination_type == ceres::FAILURE;
  result->message = summary.message;
  return true;
}

void LatentFitter::EstimateUncertainty(ceres::Problem* problem, const std::vector<double*>& blocks,
                                       const std::vector<ceres::ResidualBlockId>& data_blocks,
                                       double data_weight, FitEquilibrium* equilibrium,
                                       LatentFitResult* result) {
  std::vector<int> sizes;
  for (double* block : blocks) sizes.push_back(problem->ParameterBlockSize(block));
  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t i = 0; i < blocks.size(); ++i) {
    for (size_t j = i; j < blocks.size(); ++j) pairs.emplace_back(blocks[i], blocks[j]);
  }
  // (J^T J)^-1 of the cost at the result (a pseudo-inverse without the directions the
  // data and priors leave flat). Evaluating J prepares the point's derivatives.
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = -1;
  covariance_options.num_threads = options_.num_threads;
  ceres::Covariance covariance(covariance_options);
  if (!covariance.Compute(pairs, problem)) {
    result->uncertainty_message = "the covariance of the fitted parameters could not be computed";
    return;
  }
  int total = 0;
  std::vector<int> offsets;
  for (int size : sizes) {
    offsets.push_back(total);
    total += size;
  }
  Eigen::MatrixXd inverse(total, total);
  for (size_t i = 0; i < blocks.size(); ++i) {
    for (size_t j = i; j < blocks.size(); ++j) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(sizes[i],
                                                                                   sizes[j]);
      covariance.GetCovarianceBlock(blocks[i], blocks[j], block.data());
      inverse.block(offsets[i], offsets[j], sizes[i], sizes[j]) = block;
      inverse.block(offsets[j], offsets[i], sizes[j], sizes[i]) = block.transpose();
    }
  }
  // The noise: the data blocks' cost is (1/2) sum r^2 over N residuals; with P
  // parameters its per-residual variance is 2 cost / (N - P). The parameters' posterior
  // covariance under that noise is this variance times (J^T J)^-1.
  double data_cost = 0.0;
  int residuals = 0;
  for (ceres::ResidualBlockId id : data_blocks) {
    double cost = 0.0;
    if (!problem->EvaluateResidualBlock(id, true, &cost, nullptr, nullptr)) {
      result->uncertainty_message = "the data residuals could not be evaluated at the result";
      return;
    }
    data_cost += cost;
    residuals += problem->GetCostFunctionForResidualBlock(id)->num_residuals();
  }
  if (residuals <= total) {
    result->uncertainty_message = "fewer data residuals (" + std::to_string(residuals) +
                                  ") than parameters (" + std::to_string(total) + ")";
    return;
  }
  const double variance = 2.0 * data_cost / (residuals - total);
  result->parameter_covariance = variance * inverse;
  // The residuals are scaled by sqrt(w_k / W) (FitCost); sigma in model units is the
  // unscaled residuals' standard deviation.
  result->noise_sigma = std::sqrt(variance * data_weight);
  // dx*/dparameters at the result (the covariance's Jacobian prepared it).
  const FitEquilibrium::Point* point = equilibrium->Prepare(blocks.data(), true);
  if (point == nullptr) {
    result->parameter_covariance.resize(0, 0);
    result->uncertainty_message = "the equilibrium's derivatives could not be prepared";
    return;
  }
  const Eigen::Index rows = 3 * static_cast<Eigen::Index>(point->state.cols());
  Eigen::MatrixXd dx(rows, total);
  dx.leftCols(sizes[0]) = equilibrium->LatentProduct();
  for (size_t b = 1; b < blocks.size(); ++b) {
    dx.middleCols(offsets[b], 6) = equilibrium->BoneProduct(b - 1);
  }
  const int ns = model_.num_surface_vertices();
  result->surface_std.resize(ns);
  for (int v = 0; v < ns; ++v) {
    const PointStencil stencil = EmbeddingStencil(model_.embedding, model_.mesh.tets, v);
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(3, total);
    for (int j = 0; j < 4; ++j) {
      g += stencil.weight[j] * dx.middleRows(3 * static_cast<Eigen::Index>(stencil.vertex[j]), 3);
    }
    result->surface_std[v] =
        std::sqrt(std::max(0.0, (g * result->parameter_covariance * g.transpose()).trace()));
  }
}

bool LatentFitter::FitPointCloud(const Eigen::Matrix3Xd& points,
                                 const PointCloudFitOptions& cloud_options,
                                 const Eigen::VectorXd& initial, LatentFitResult* result,
                                 std::string* error) {
  if (points.cols() < 3) {
    *error = "a point cloud needs at least 3 points";
    return false;
  }
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  if (!Simulate(z, &state, &surface, error)) {
    result->latent = z;
    result->bones = bones_;
    result->state = state;
    result->surface = surface;
    return false;
  }
  const Eigen::Matrix3Xi& triangles = model_.neutral.triangles;
  const FitTarget& landmarks = cloud_options.landmarks;
  cloud_options_ = &cloud_options;
  cloud_bone_centres_.assign(bones_.size(), Eigen::Matrix<double, 6, 1>::Zero());
  for (size_t b = 0; b < bones_.size(); ++b) {
    BoneTransformToParameters(bones_[b], cloud_bone_centres_[b].data());
  }
  if (cloud_options.rematch_every_evaluation) {
    // One Levenberg-Marquardt solve of the robust closest-point distances.
    direct_cloud_ = &points;
    const bool ok = FitFrom(FitTarget(), z, result, error);
    direct_cloud_ = nullptr;
    cloud_options_ = nullptr;
    if (!ok) return false;
    result->round_distances.clear();
  } else {
  double previous_mean = -1.0;
  int total_iterations = 0;
  LatentFitResult totals;
  std::vector<double> round_distances;
  LatentFitOptions saved = options_;
  options_.max_iterations = cloud_options.iterations_per_round;
  bool ok = true;
  for (int round = 0; round < cloud_options.max_rounds; ++round) {
    int used = 0;
    double mean = 0.0;
    const FitTarget target = MatchPointCloud(points, surface, triangles, cloud_options,
                                             options_.num_threads, &used, &mean);
    if (used < 3) {
      *error = "fewer than 3 scan points lie within --max_distance of the model's surface: is "
               "the scan in the model's frame and units?";
      ok = false;
      break;
    }
    round_distances.push_back(mean);
    if (previous_mean >= 0 &&
        std::abs(previous_mean - mean) <= cloud_options.relative_tolerance * previous_mean) {
      break;
    }
    previous_mean = mean;
    if (!FitFrom(target, z, result, error)) {
      ok = false;
      break;
    }
    total_iterations += result->iterations;
    totals.solves += result->solves;
    totals.solve_factorizations += result->solve_factorizations;
    totals.solve_seconds += result->solve_seconds;
    totals.jacobians += result->jacobians;
    totals.jacobian_seconds += result->jacobian_seconds;
    z = result->latent;
    surface = result->surface;
  }
  options_ = saved;
  cloud_options_ = nullptr;
  if (!ok) return false;
  result->iterations = total_iterations;
  result->round_distances = round_distances;
  result->solves = totals.solves;
  result->solve_factorizations = totals.solve_factorizations;
  result->solve_seconds = totals.solve_seconds;
  result->jacobians = totals.jacobians;
  result->jacobian_seconds = totals.jacobian_seconds;
  }
  // Final distances from the scan to the fitted surface (closest points).
  const TriangleBvh bvh(result->surface, triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, options_.num_threads);
  double sum = 0, sum_squares = 0, worst = 0;
  int used = 0;
  for (const ClosestPointResult& c : closest) {
    if (cloud_options.max_distance > 0 && c.distance > cloud_options.max_distance) continue;
    ++used;
    sum += c.distance;
    sum_squares += c.distance * c.distance;
    worst = std::max(worst, c.distance);
  }
  result->used_points = used;
  result->matched_fraction = static_cast<double>(used) / static_cast<double>(points.cols());
  result->landmark_mean_error = 0.0;
  if (landmarks.num_points() > 0) {
    const Eigen::Matrix3Xd on_surface = TargetPointsOn(landmarks, result->surface);
    result->landmark_mean_error = (on_surface - landmarks.positions).colwise().norm().mean();
  }
  result->mean_error = used > 0 ? sum / used : 0.0;
  result->rms_error = used > 0 ? std::sqrt(sum_squares / used) : 0.0;
  result->max_error = worst;
  return true;
}

double LatentFitter::Objective(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                               const Eigen::VectorXd& z) const {
  return ObjectiveWithBonePrior(target, surface, z, options_.bone_prior);
}

double LatentFitter::ObjectiveWithBonePrior(const FitTarget& target,
                                            const Eigen::Matrix3Xd& surface,
                                            const Eigen::VectorXd& z, double bone_prior) const {
  double cost =
      TargetDataTerm(target, surface) + options_.latent_regularization * z.squaredNorm();
  const double prior_points = PriorPoints(target, options_.prior_points_cap);
  if (options_.latent_prior > 0) {
    cost += options_.latent_prior / prior_points * prior_.latent.SquaredMahalanobis(z);
  }
  if (options_.fit_bones && bone_prior > 0) {
    for (size_t b = 0; b < bones_.size(); ++b) {
      Eigen::VectorXd parameters(6);
      BoneTransformToParameters(bones_[b], parameters.data());
      cost += bone_prior / prior_points * prior_.bones[b].SquaredMahalanobis(parameters);
    }
  }
  return cost;
}

double LatentFitter::StartObjective(const FitTarget* target, const Eigen::Matrix3Xd* points,
                                    const PointCloudFitOptions& cloud_options,
                                    const Eigen::Matrix3Xd& surface,
                                    const Eigen::VectorXd& z) const {
  CHECK((target != nullptr) != (points != nullptr));
  if (target != nullptr) return Objective(*target, surface, z);
  int used = 0;
  double mean = 0.0;
  const FitTarget matched = MatchPointCloud(*points, surface, model_.neutral.triangles,
                                            cloud_options, options_.num_threads, &used, &mean);
  if (used < 3) return std::numeric_limits<double>::infinity();
  // Without the bone prior: a scan fit's is centred on its start, so every start is at
  // its centre.
  double cost = ObjectiveWithBonePrior(matched, surface, z, 0.0);
  if (cloud_options.landmarks.num_points() > 0 && cloud_options.landmark_weight > 0) {
    cost += cloud_options.landmark_weight * TargetDataTerm(cloud_options.landmarks, surface);
  }
  return cost;
}

bool LatentFitter::ChooseStart(const FitTarget* target, const Eigen::Matrix3Xd* points,
                               const PointCloudFitOptions& cloud_options,
                               const FitStartOptions& options, Eigen::VectorXd* z,
                               std::string* name, std::string* error) {
  CHECK((target != nullptr) != (points != nullptr));
  CHECK_EQ(z->size(), model_.latent_dim());
  auto score = [&](const Eigen::Matrix3Xd& surface, const Eigen::VectorXd& latent) {
    return StartObjective(target, points, cloud_options, surface, latent);
  };
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_z = *z;
  std::vector<RigidTransform> best_bones = bones_;
  Eigen::Matrix3Xd best_state;
  std::string best_name;
  // The given start is a training pose's (e.g. the prior's centre, the neutral): that
  // candidate covers it, with its stored equilibrium instead of a solve.
  bool given_is_training_pose = false;
  for (int p = 0; options.training_poses && p < model_.num_poses(); ++p) {
    bool same = p < static_cast<int>(model_.states.size()) &&
                model_.states[p].cols() == model_.mesh.num_vertices() &&
                *z == Eigen::VectorXd(model_.latents.col(p));
    for (size_t b = 0; same && b < bones_.size(); ++b) {
      same = bones_[b].rotation == model_.bones[b].pose_transforms[p].rotation &&
             bones_[b].translation == model_.bones[b].pose_transforms[p].translation;
    }
    given_is_training_pose |= same;
  }
  if (!given_is_training_pose) {
    Eigen::Matrix3Xd state, surface;
    std::string simulate_error;
    if (Simulate(*z, &state, &surface, &simulate_error)) {
      best = score(surface, *z);
      best_state = state;
      best_name = "given";
    } else {
      *error = simulate_error;
    }
  }
  const std::vector<RigidTransform> given_bones = bones_;
  for (int p = 0; options.training_poses && p < model_.num_poses(); ++p) {
    if (p >= static_cast<int>(model_.states.size()) ||
        model_.states[p].cols() != model_.mesh.num_vertices()) {
      continue;
    }
    for (size_t b = 0; b < bones_.size(); ++b) bones_[b] = model_.bones[b].pose_transforms[p];
    const Eigen::Matrix3Xd surface =
        EmbeddedPositions(model_.embedding, model_.mesh.tets, model_.states[p]);
    const double s = score(surface, model_.latents.col(p));
    if (s < best) {
      best = s;
      best_z = model_.latents.col(p);
      best_bones = bones_;
      best_state = model_.states[p];
      best_name = model_.poses[p].name;
    }
  }
  bones_ = given_bones;
  if (best_name.empty()) {
    *error = "no start: " + *error;
    return false;
  }
  set_bone_transforms(best_bones);
  set_start_state(best_state);
  *z = best_z;
  *name = best_name;
  return true;
}

}  // namespace aqs
