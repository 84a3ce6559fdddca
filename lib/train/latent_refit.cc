#include "train/latent_refit.h"

#include <glog/logging.h>

#include <algorithm>
#include <memory>
#include <numeric>
#include <vector>

#include "fit/latent_fit.h"
#include "geometry/embedding.h"
#include "learn/decoder.h"
#include "physics/shape_target_model.h"
#include "util/option_checks.h"
#include "util/parallel_for.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// The pose's share of the training loss at latent z and its equilibrium x:
// (1/N) sum_i |surface_i - y_i|^2 + lambda |z|^2 + energy_regularization E(x, a(z)) /
// (sum_e mu_e V_e) (the last term only where energy_regularization > 0).
double PoseObjective(const LatentRefitOptions& options, const ActiveModel& model,
                     const ShapeTargetModel& physics, const Eigen::Matrix3Xd& x,
                     const Eigen::Matrix3Xd& target, const Eigen::VectorXd& z,
                     DecoderWorkspace* workspace) {
  const Eigen::Matrix3Xd surface = EmbeddedPositions(model.embedding, model.mesh.tets, x);
  double objective = (surface - target).squaredNorm() / static_cast<double>(target.cols()) +
                     options.latent_regularization * z.squaredNorm();
  if (options.energy_regularization > 0.0) {
    ActuationMatrix a;
    model.decoder->Decode(model.decoder_params.data(), z, &a, workspace);
    objective += options.energy_regularization * physics.Energy(x, a, 1) /
                 physics.stiffness_volume();
  }
  return objective;
}

}  // namespace

bool LatentRefitOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .InRange("latent_regularization", latent_regularization, 0.0, kMaxRegularization)
      .InRange("energy_regularization", energy_regularization, 0.0, kMaxRegularization)
      .IntAtLeast("max_iterations", max_iterations, 0)
      .Nested("solver", solver_ok, solver_error)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Done(error);
}

LatentRefitReport RefitTrainingLatents(const LatentRefitOptions& options, ActiveModel* model,
                                       const std::vector<int>* poses) {
  std::string invalid;
  CHECK(options.Validate(&invalid)) << "latent refit options: " << invalid;
  CHECK(model->decoder) << "latent refits need a decoder";
  const int num_poses = model->num_poses();
  CHECK_EQ(static_cast<int>(model->states.size()), num_poses) << "one state per pose";
  std::vector<int> all;
  if (poses == nullptr) {
    all.resize(num_poses);
    std::iota(all.begin(), all.end(), 0);
    poses = &all;
  }
  for (int p : *poses) CHECK(p >= 0 && p < num_poses) << "pose " << p;
  const int count = static_cast<int>(poses->size());
  WallTimer timer;
  LatentFitOptions fit;
  fit.latent_prior = 0.0;
  fit.bone_prior = 0.0;
  fit.latent_regularization = options.latent_regularization;
  fit.fit_bones = false;
  fit.coarse_points = 0;  // from the pose's own equilibrium: one fit (whatever the default)
  fit.max_iterations = options.max_iterations;
  fit.solver = options.solver;
  fit.num_threads = 1;
  const int num_threads = ParallelForThreadCount(options.num_threads, std::max(1, count), 1);
  std::vector<std::unique_ptr<LatentFitter>> fitters(num_threads);
  std::vector<double> before(num_poses, 0.0), after(num_poses, 0.0);
  std::vector<char> improved(num_poses, 0), failed(num_poses, 0);
  std::vector<Eigen::VectorXd> latents(num_poses);
  std::vector<Eigen::Matrix3Xd> states(num_poses);
  const ActiveModel& fixed = *model;
  const ShapeTargetModel physics(fixed.mesh, fixed.mu);
  std::vector<DecoderWorkspace> workspaces(num_threads);
  ParallelFor(
      num_threads, 0, count,
      [&](int thread, int k) {
        const int p = (*poses)[k];
        if (!fitters[thread]) fitters[thread] = std::make_unique<LatentFitter>(fixed, fit);
        LatentFitter& fitter = *fitters[thread];
        const Eigen::Matrix3Xd& target = fixed.poses[p].surface;
        const Eigen::VectorXd z = fixed.latents.col(p);
        before[p] = PoseObjective(options, fixed, physics, fixed.states[p], target, z,
                                  &workspaces[thread]);
        after[p] = before[p];
        std::vector<RigidTransform> bones(fixed.bones.size());
        for (size_t b = 0; b < bones.size(); ++b) bones[b] = fixed.bones[b].pose_transforms[p];
        fitter.set_bone_transforms(bones);
        fitter.set_start_state(fixed.states[p]);
        // A pose's refit must not depend on which poses its thread (or rank) did before.
        fitter.ForgetFactor();
        LatentFitResult result;
        std::string error;
        if (!fitter.Fit(FullSurfaceTarget(target), z, &result, &error) || result.failed) {
          failed[p] = 1;
          return;
        }
        const double objective = PoseObjective(options, fixed, physics, result.state, target,
                                               result.latent, &workspaces[thread]);
        if (objective < before[p]) {
          after[p] = objective;
          improved[p] = 1;
          latents[p] = result.latent;
          states[p] = result.state;
        }
      },
      1);
  LatentRefitReport report;
  for (int p : *poses) {
    report.loss_before += before[p] / num_poses;
    report.loss_after += after[p] / num_poses;
    report.failed += failed[p];
    if (!improved[p]) continue;
    ++report.improved;
    model->latents.col(p) = latents[p];
    model->states[p] = states[p];
  }
  report.seconds = timer.Seconds();
  return report;
}

}  // namespace aqs
