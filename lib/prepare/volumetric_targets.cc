#include "prepare/volumetric_targets.h"

#include <iomanip>
#include <memory>
#include <mutex>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "equilibrium/embedded_attachments.h"
#include "geometry/embedding.h"
#include "prepare/target_store.h"
#include "util/parallel_for.h"
#include "util/wall_timer.h"
#include "util/option_checks.h"

namespace aqs {

Eigen::Matrix3d SymmetricPolarFactor(const Eigen::Matrix3d& f) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullV);
  const Eigen::Matrix3d v = svd.matrixV();
  Eigen::Matrix3d s = v * svd.singularValues().asDiagonal() * v.transpose();
  return 0.5 * (s + s.transpose());
}

Eigen::VectorXd AttachmentStiffness(const ActiveModel& model, double relative_stiffness) {
  // Springs: per unit area as stiff as relative_stiffness layers of elements. Surface
  // vertices with no area (isolated) get the mean.
  Eigen::VectorXd stiffness = VertexAreas(model.neutral.vertices, model.neutral.triangles);
  const double mean_area = stiffness.sum() / std::max<Eigen::Index>(1, stiffness.size());
  for (Eigen::Index i = 0; i < stiffness.size(); ++i) {
    if (!(stiffness[i] > 0)) stiffness[i] = mean_area;
  }
  return stiffness * (relative_stiffness * model.mu.mean() / MeanEdgeLength(model.mesh));
}

bool VolumetricTargetOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Positive("relative_stiffness", relative_stiffness)
      .InRange("relative_stiffness", relative_stiffness, 0.0, kMaxRelativeStiffness)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .IntInRange("continuation_steps", continuation_steps, 1, 1000)
      .Done(error);
}

double EquilibriumSolverMemoryBytes(double num_elements) {
  constexpr double kBytesPerElement = 8000.0;
  constexpr double kMeasuredElements = 257250.0;
  return kBytesPerElement * num_elements *
         std::max(1.0, std::cbrt(num_elements / kMeasuredElements));
}

bool MakeVolumetricTargets(const VolumetricTargetOptions& options, ActiveModel* model,
                           std::ostream& log, std::string* error,
                           std::vector<std::string>* unconverged) {
  if (!options.Validate(error)) return false;
  const ShapeTargetModel physics(model->mesh, model->mu);
  const int num_poses = model->num_poses();
  const Eigen::VectorXd stiffness = AttachmentStiffness(*model, options.relative_stiffness);

  const int threads = std::max(1, std::min(options.num_threads, num_poses));
  struct Worker {
    std::unique_ptr<QuasistaticSolver> solver;
    std::unique_ptr<EmbeddedAttachments> springs;
  };
  std::vector<Worker> workers(threads);
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = 1;  // parallel over poses instead
  std::mutex log_mutex;
  std::vector<std::string> failures(num_poses);
  TargetStore store;
  if (!options.store_directory.empty() &&
      !store.Open(options.store_directory, VolumetricTargetKey(options, *model), error)) {
    return false;
  }
  int from_store = 0;
  ParallelFor(threads, 0, num_poses, [&](int t, int p) {
    WallTimer timer;
    TrainingPose& pose = model->poses[p];
    if (store.Load(p, physics.num_elements(), &pose, &failures[p])) {
      std::lock_guard<std::mutex> lock(log_mutex);
      ++from_store;
      return;
    }
    Worker& w = workers[t];
    if (!w.solver) {
      w.solver = std::make_unique<QuasistaticSolver>(physics, PoseBoundaryConditions(*model, 0),
                                                     solver_options);
      w.springs = std::make_unique<EmbeddedAttachments>(model->embedding, model->mesh.tets,
                                                        stiffness, model->mesh.vertices);
      w.solver->AddEnergyTerm(w.springs.get());
    }
    const BoundaryConditions bc = PoseBoundaryConditions(*model, p);
    const Eigen::Matrix3Xd rest_fixed = ModelBoundaryConditions(*model, RestBoneTransforms(*model)).positions;
    const Eigen::Matrix3Xd rest_points =
        EmbeddedPositions(model->embedding, model->mesh.tets, model->mesh.vertices);
    // Direct solve from rest; if it fails, continuation from rest to the pose.
    w.solver->SetPositions(model->mesh.vertices);
    w.solver->SetFixedPositions(bc.positions);
    w.springs->targets() = pose.surface;
    QuasistaticSolveReport report = w.solver->Solve();
    int steps = 1;
    if (!report.converged && options.continuation_steps > 1) {
      steps = options.continuation_steps;
      w.solver->SetPositions(model->mesh.vertices);
      for (int s = 1; s <= steps && (s == 1 || report.converged); ++s) {
        const double alpha = static_cast<double>(s) / steps;
        w.solver->SetFixedPositions((1 - alpha) * rest_fixed + alpha * bc.positions);
        w.springs->targets() = (1 - alpha) * rest_points + alpha * pose.surface;
        report = w.solver->Solve();
      }
    }
    if (!report.converged) {
      failures[p] = "pose '" + pose.name + "': the embedded simulation did not converge: " +
                    report.Summary();
      if (unconverged == nullptr || !w.solver->positions().allFinite()) return;
    }
    const Eigen::Matrix3Xd x = w.solver->positions();
    pose.target.resize(6, physics.num_elements());
    for (int e = 0; e < physics.num_elements(); ++e) {
      pose.target.col(e) = ActuationFromSymmetric(SymmetricPolarFactor(physics.DeformationGradient(x, e)));
    }
    const Eigen::VectorXd distance =
        (w.springs->Points(x) - pose.surface).colwise().norm();
    pose.embedding_mean_error = distance.mean();
    pose.embedding_max_error = distance.maxCoeff();
    std::string store_error;
    const bool stored = options.store_directory.empty() ||
                        store.Save(p, pose, failures[p], &store_error);
    std::lock_guard<std::mutex> lock(log_mutex);
    if (!stored) log << "  warning: pose '" << pose.name << "' not kept: " << store_error << "\n";
    log << "  " << std::left << std::setw(22) << pose.name << std::right << " surface error mean "
        << std::setprecision(3) << pose.embedding_mean_error << " max " << pose.embedding_max_error
        << " (pose moves up to " << (pose.surface - model->neutral.vertices).colwise().norm().maxCoeff()
        << "), " << report.Path()
        << (steps > 1 ? " in " + std::to_string(steps) + " steps" : std::string()) << ", "
        << timer.Seconds() << " s" << (report.converged ? "" : ", NOT CONVERGED") << "\n"
        << std::flush;
  }, 1);
  if (from_store > 0) {
    log << "  " << from_store << " of " << num_poses << " poses' targets were taken from "
        << options.store_directory << " (an earlier run of the same preparation)\n";
  }
  for (const std::string& failure : failures) {
    if (failure.empty()) continue;
    if (unconverged == nullptr) {
      *error = failure;
      return false;
    }
    unconverged->push_back(failure);
  }
  return true;
}

}  // namespace aqs
