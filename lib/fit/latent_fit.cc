#include "fit/latent_fit.h"

#include <cmath>
#include <sstream>

#include <ceres/cost_function.h>
#include <ceres/jet.h>
#include <ceres/problem.h>
#include <ceres/rotation.h>
#include <ceres/solver.h>
#include <Eigen/Geometry>
#include <glog/logging.h>

#include "fit/latent_prior.h"
#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"

namespace aqs {

FitTarget VertexTarget(const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions) {
  CHECK_EQ(positions.cols(), static_cast<Eigen::Index>(vertices.size()));
  FitTarget target;
  const int k = static_cast<int>(vertices.size());
  target.vertices.resize(3, k);
  target.barycentric.setZero(3, k);
  for (int i = 0; i < k; ++i) {
    target.vertices.col(i).setConstant(vertices[i]);
    target.barycentric(0, i) = 1.0;
  }
  target.positions = positions;
  return target;
}

FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface) {
  std::vector<int> all(surface.cols());
  for (Eigen::Index i = 0; i < surface.cols(); ++i) all[i] = static_cast<int>(i);
  return VertexTarget(all, surface);
}

RigidTransform BoneTransformFromParameters(const double* parameters) {
  const Eigen::Vector3d omega(parameters[0], parameters[1], parameters[2]);
  RigidTransform t;
  const double angle = omega.norm();
  if (angle > 0) t.rotation = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  t.translation = Eigen::Vector3d(parameters[3], parameters[4], parameters[5]);
  return t;
}

void BoneTransformToParameters(const RigidTransform& transform, double* parameters) {
  const Eigen::AngleAxisd aa(transform.rotation);
  const Eigen::Vector3d omega = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) {
    parameters[i] = omega[i];
    parameters[3 + i] = transform.translation[i];
  }
}

namespace {

// d (R(omega) X) / d omega (3x3) at omega, for the rotation-vector parameterization,
// by forward-mode differentiation of Ceres' AngleAxisRotatePoint.
Eigen::Matrix3d RotatedPointJacobian(const double* omega, const Eigen::Vector3d& point) {
  using Jet = ceres::Jet<double, 3>;
  Jet w[3], p[3], out[3];
  for (int i = 0; i < 3; ++i) {
    w[i] = Jet(omega[i], i);
    p[i] = Jet(point[i]);
  }
  ceres::AngleAxisRotatePoint(w, p, out);
  Eigen::Matrix3d jacobian;
  for (int i = 0; i < 3; ++i) jacobian.row(i) = out[i].v.transpose();
  return jacobian;
}

}  // namespace

// Residuals sqrt(w_k / sum w) (p_k(x*) - y_k) (3 K) over the blocks z and, if fitted,
// one 6-number block per bone.
class LatentFitter::FitCost final : public ceres::CostFunction {
 public:
  FitCost(LatentFitter* fitter, const FitTarget& target, bool fit_bones)
      : fitter_(fitter), target_(target), fit_bones_(fit_bones) {
    const ActiveModel& model = fitter->model_;
    const int k = target.num_points();
    set_num_residuals(3 * k);
    mutable_parameter_block_sizes()->push_back(model.latent_dim());
    if (fit_bones_) {
      for (size_t b = 0; b < model.bones.size(); ++b) mutable_parameter_block_sizes()->push_back(6);
    }
    for (int size : parameter_block_sizes()) parameter_count_ += size;
    double total = 0.0;
    for (int i = 0; i < k; ++i) total += target.weights.size() > 0 ? target.weights[i] : 1.0;
    CHECK_GT(total, 0.0) << "fit targets need a positive total weight";
    // Each target point as a combination of 12 state vertices plus a constant offset.
    stencils_.resize(k);
    for (int i = 0; i < k; ++i) {
      Stencil& s = stencils_[i];
      const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
      s.scale = std::sqrt(w / total);
      s.offset.setZero();
      for (int c = 0; c < 3; ++c) {
        const int v = target.vertices(c, i);
        CHECK(v >= 0 && v < model.num_surface_vertices()) << "target vertex " << v;
        const double beta = target.barycentric(c, i);
        s.offset += beta * model.embedding.offsets.col(v);
        for (int j = 0; j < 4; ++j) {
          s.vertex[4 * c + j] = model.mesh.tets(j, model.embedding.element[v]);
          s.weight[4 * c + j] = beta * model.embedding.weights(j, v);
        }
      }
    }
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const ActiveModel& model = fitter_->model_;
    const int d = model.latent_dim();
    const Eigen::Map<const Eigen::VectorXd> z(parameters[0], d);
    const bool want_z = jacobians != nullptr && jacobians[0] != nullptr;
    ActuationMatrix a;
    Eigen::MatrixXd da_dz;
    if (want_z) {
      da_dz = model.decoder->ActuationJacobian(model.decoder_params.data(), z, &a);
    } else {
      DecoderWorkspace workspace;
      model.decoder->Decode(model.decoder_params.data(), z, &a, &workspace);
    }
    std::vector<RigidTransform> bones = fitter_->bones_;
    if (fit_bones_) {
      for (size_t b = 0; b < bones.size(); ++b) bones[b] = BoneTransformFromParameters(parameters[1 + b]);
    }
    // The equilibrium at these parameters, warm-started from that of the last accepted
    // point (never from a rejected trial's: with a non-convex energy the branch a solve
    // lands on depends on its start, and the cost must be a function of the parameters
    // along the branch the fit follows). The last evaluation is remembered, so that the
    // Jacobian evaluation at an accepted point reuses its equilibrium.
    Eigen::VectorXd key(parameter_count_);
    for (int b = 0, offset = 0; b < static_cast<int>(parameter_block_sizes().size()); ++b) {
      const int size = parameter_block_sizes()[b];
      key.segment(offset, size) = Eigen::Map<const Eigen::VectorXd>(parameters[b], size);
      offset += size;
    }
    if (!(last_key_.size() == key.size() && last_key_ == key)) {
      QuasistaticSolver& solver = *fitter_->solver_;
      solver.SetPositions(fitter_->accepted_state_);
      solver.SetFixedPositions(ModelBoundaryConditions(model, bones).positions);
      solver.actuation() = a;
      const QuasistaticSolveReport report = solver.Solve();
      last_key_.resize(0);
      if (!report.converged) return false;  // Ceres treats the step as unsuccessful
      last_key_ = key;
      last_state_ = solver.positions();
    }
    const Eigen::Matrix3Xd& x = last_state_;
    // Trust-region minimizers evaluate Jacobians only at accepted points.
    if (jacobians != nullptr) fitter_->accepted_state_ = x;
    const int k = target_.num_points();
    for (int i = 0; i < k; ++i) {
      const Stencil& s = stencils_[i];
      Eigen::Vector3d p = s.offset;
      for (int j = 0; j < 12; ++j) p += s.weight[j] * x.col(s.vertex[j]);
      Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = s.scale * (p - target_.positions.col(i));
    }
    if (jacobians == nullptr) return true;
    bool want_bones = false;
    for (size_t b = 0; fit_bones_ && b < bones.size(); ++b) want_bones |= jacobians[1 + b] != nullptr;
    if (!want_z && !want_bones) return true;
    std::string error;
    if (!fitter_->differentiator_->Prepare(x, a, &error)) return false;
    if (want_z) {
      const Eigen::MatrixXd dx_dz = fitter_->differentiator_->ActuationJacobianProduct(da_dz);
      FillJacobian(dx_dz, jacobians[0]);
    }
    for (size_t b = 0; fit_bones_ && b < bones.size(); ++b) {
      if (jacobians[1 + b] == nullptr) continue;
      Eigen::MatrixXd motion = Eigen::MatrixXd::Zero(3 * static_cast<Eigen::Index>(x.cols()), 6);
      for (int v : model.bones[b].vertices) {
        motion.block<3, 3>(3 * static_cast<Eigen::Index>(v), 0) =
            RotatedPointJacobian(parameters[1 + b], model.mesh.vertices.col(v));
        motion.block<3, 3>(3 * static_cast<Eigen::Index>(v), 3) = Eigen::Matrix3d::Identity();
      }
      FillJacobian(fitter_->differentiator_->FixedVertexJacobianProduct(motion), jacobians[1 + b]);
    }
    return true;
  }

 private:
  struct Stencil {
    int vertex[12];
    double weight[12];
    Eigen::Vector3d offset;
    double scale;
  };

  // Row-major (3K x columns) Jacobian of the residuals from dx (3 num_vertices x columns).
  void FillJacobian(const Eigen::MatrixXd& dx, double* out) const {
    const Eigen::Index columns = dx.cols();
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
        out, 3 * target_.num_points(), columns);
    for (int i = 0; i < target_.num_points(); ++i) {
      const Stencil& s = stencils_[i];
      Eigen::MatrixXd dp = Eigen::MatrixXd::Zero(3, columns);
      for (int j = 0; j < 12; ++j) {
        if (s.weight[j] != 0.0) dp += s.weight[j] * dx.middleRows(3 * static_cast<Eigen::Index>(s.vertex[j]), 3);
      }
      jac.middleRows(3 * i, 3) = s.scale * dp;
    }
  }

  LatentFitter* fitter_;
  const FitTarget& target_;
  bool fit_bones_;
  std::vector<Stencil> stencils_;
  int parameter_count_ = 0;
  // The last evaluated parameters (all blocks, concatenated) and their equilibrium.
  mutable Eigen::VectorXd last_key_;
  mutable Eigen::Matrix3Xd last_state_;
};

LatentFitter::LatentFitter(const ActiveModel& model, const LatentFitOptions& options)
    : model_(model), options_(options), bones_(RestBoneTransforms(model)),
      accepted_state_(model.mesh.vertices) {
  CHECK(model.decoder) << "latent fitting needs a trained model";
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

Eigen::VectorXd LatentFitter::MeanLatent() const { return model_.latents.rowwise().mean(); }

ceres::CostFunction* LatentFitter::NewCostFunction(const FitTarget& target) {
  return new FitCost(this, target, options_.fit_bones && !model_.bones.empty());
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
  QuasistaticSolveReport report = solver_->Solve();
  if (!report.converged) {  // once more from rest
    solver_->SetPositions(model_.mesh.vertices);
    report = solver_->Solve();
  }
  last_simulate_report_ = report;
  if (!report.converged) {
    *error = "the equilibrium was not reached: " + report.Summary();
    return false;
  }
  *state = solver_->positions();
  accepted_state_ = *state;
  *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
  return true;
}

bool LatentFitter::Fit(const FitTarget& target, const Eigen::VectorXd& initial,
                       LatentFitResult* result, std::string* error) {
  const int d = model_.latent_dim();
  CHECK_EQ(initial.size(), d);
  CHECK_EQ(target.vertices.cols(), target.positions.cols());
  CHECK_EQ(target.barycentric.cols(), target.positions.cols());
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  if (!Simulate(z, &state, &surface, error)) {
    *error = "at the initial latent: " + *error;
    return false;
  }
  const bool fit_bones = options_.fit_bones && !model_.bones.empty();
  std::vector<Eigen::Matrix<double, 6, 1>> bone_parameters(model_.bones.size());
  for (size_t b = 0; b < model_.bones.size(); ++b) {
    BoneTransformToParameters(bones_[b], bone_parameters[b].data());
  }
  ceres::Problem problem;
  std::vector<double*> blocks = {z.data()};
  if (fit_bones) {
    for (auto& p : bone_parameters) blocks.push_back(p.data());
  }
  problem.AddResidualBlock(new FitCost(this, target, fit_bones), nullptr, blocks);
  if (options_.latent_regularization > 0) {
    problem.AddResidualBlock(new LatentPrior(d, options_.latent_regularization), nullptr, z.data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.function_tolerance = 1e-10;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-10;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (fit_bones) {
    for (size_t b = 0; b < model_.bones.size(); ++b) {
      bones_[b] = BoneTransformFromParameters(bone_parameters[b].data());
    }
  }
  if (!Simulate(z, &state, &surface, error)) return false;
  result->latent = z;
  result->bones = bones_;
  result->state = state;
  result->surface = surface;
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
  result->converged = summary.termination_type == ceres::CONVERGENCE;
  result->message = summary.message;
  return true;
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
  if (!Simulate(z, &state, &surface, error)) return false;
  const Eigen::Matrix3Xi& triangles = model_.neutral.triangles;
  double previous_mean = -1.0;
  int total_iterations = 0;
  LatentFitOptions saved = options_;
  options_.max_iterations = cloud_options.iterations_per_round;
  bool ok = true;
  for (int round = 0; round < cloud_options.max_rounds; ++round) {
    // Match every scan point to the closest point of the current surface.
    const TriangleBvh bvh(surface, triangles);
    const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, options_.num_threads);
    FitTarget target;
    const Eigen::Index m = points.cols();
    target.vertices.resize(3, m);
    target.barycentric.resize(3, m);
    target.positions = points;
    target.weights.resize(m);
    int used = 0;
    double mean = 0.0;
    for (Eigen::Index i = 0; i < m; ++i) {
      const ClosestPointResult& c = closest[i];
      target.vertices.col(i) = triangles.col(c.triangle);
      target.barycentric.col(i) = c.barycentric;
      double w = 1.0;
      if (cloud_options.max_distance > 0 && c.distance > cloud_options.max_distance) w = 0.0;
      if (w > 0 && cloud_options.robust_scale > 0) {
        const double r = c.distance / cloud_options.robust_scale;
        w = 1.0 / (1.0 + r * r);
      }
      target.weights[i] = w;
      if (w > 0) {
        ++used;
        mean += c.distance;
      }
    }
    if (used < 3) {
      *error = "fewer than 3 scan points lie within --max_distance of the model's surface: is "
               "the scan in the model's frame and units?";
      ok = false;
      break;
    }
    mean /= used;
    if (previous_mean >= 0 &&
        std::abs(previous_mean - mean) <= cloud_options.relative_tolerance * previous_mean) {
      break;
    }
    previous_mean = mean;
    if (!Fit(target, z, result, error)) {
      ok = false;
      break;
    }
    total_iterations += result->iterations;
    z = result->latent;
    surface = result->surface;
  }
  options_ = saved;
  if (!ok) return false;
  result->iterations = total_iterations;
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
  result->mean_error = used > 0 ? sum / used : 0.0;
  result->rms_error = used > 0 ? std::sqrt(sum_squares / used) : 0.0;
  result->max_error = worst;
  return true;
}

}  // namespace aqs
