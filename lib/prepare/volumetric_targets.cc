#include "prepare/volumetric_targets.h"

#include <algorithm>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <glog/logging.h>

#include "equilibrium/embedded_attachments.h"
#include "equilibrium/rest_factor.h"
#include "geometry/embedding.h"
#include "model/surface_springs.h"
#include "physics/rotation_variant_svd.h"
#include "prepare/target_store.h"
#include "util/blas.h"
#include "util/fault_injection.h"
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

Eigen::Matrix3d SignedSymmetricFactor(const Eigen::Matrix3d& f) {
  const RotationVariantSvd svd = ComputeRotationVariantSvd(f);
  const Eigen::Matrix3d s = svd.v * svd.sigma.asDiagonal() * svd.v.transpose();
  return 0.5 * (s + s.transpose());
}

Vector6d ElementTarget(const Eigen::Matrix3d& f, InvertedTargets inverted_targets) {
  const bool exact = inverted_targets == InvertedTargets::kExact && !(f.determinant() > 0);
  return ActuationFromSymmetric(exact ? SignedSymmetricFactor(f) : SymmetricPolarFactor(f));
}

const char* InvertedTargetsName(InvertedTargets kind) {
  return kind == InvertedTargets::kExact ? "exact" : "mirror";
}

bool ParseInvertedTargets(const std::string& name, InvertedTargets* kind) {
  for (InvertedTargets k : {InvertedTargets::kExact, InvertedTargets::kMirror}) {
    if (name == InvertedTargetsName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
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

struct VolumetricTargetMaker::Worker {
  std::unique_ptr<QuasistaticSolver> solver;
  std::unique_ptr<EmbeddedAttachments> springs;
  // The factor every pose's solve starts from (RestStiffnessFactor).
  StoredStiffnessFactor start_factor;
};

VolumetricTargetMaker::VolumetricTargetMaker(const VolumetricTargetOptions& options,
                                             const ActiveModel& model)
    : options_(options),
      model_(model),
      physics_(std::make_unique<ShapeTargetModel>(model.mesh, model.mu)),
      stiffness_(SurfaceSpringStiffness(model, options.relative_stiffness)),
      workers_(std::max(1, options.num_threads)) {}  // Make uses at least one

VolumetricTargetMaker::~VolumetricTargetMaker() = default;

void MakeVolumetricTargetsOf(const VolumetricTargetOptions& options,
                             const std::vector<int>& poses, const TargetStore* store,
                             ActiveModel* model, std::ostream& log,
                             std::vector<std::string>* failures) {
  if (poses.empty()) return;
  VolumetricTargetMaker(options, *model).Make(poses, store, model, log, failures);
}

void VolumetricTargetMaker::Make(const std::vector<int>& poses, const TargetStore* store,
                                 ActiveModel* model, std::ostream& log,
                                 std::vector<std::string>* failures) {
  CHECK_EQ(model, &model_);
  CHECK_EQ(static_cast<int>(failures->size()), model->num_poses());
  const int count = static_cast<int>(poses.size());
  if (count == 0) return;
  const ShapeTargetModel& physics = *physics_;
  const VolumetricTargetOptions& options = options_;
  const int threads = std::max(1, std::min(options.num_threads, count));
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = 1;  // parallel over poses instead
  // And BLAS single-threaded meanwhile: each pose's factorizations calling a threaded
  // OpenBLAS at once made the full face's 44 targets take 26.8 s on 2 threads against
  // 15.5 s on one (docs/benchmarks.md). Also with one thread: CHOLMOD's factors then
  // have the same bits for any number of threads and ranks (threaded BLAS rounds
  // differently), and the poses' solves, starting from the rest factor, factorize little.
  const ScopedBlasThreads blas(1);
  std::mutex log_mutex;
  ParallelFor(threads, 0, count, [&](int t, int k) {
    FaultPoint("targets:pose");  // before each pose's solve
    WallTimer timer;
    const int p = poses[k];
    TrainingPose& pose = model->poses[p];
    std::string& failure = (*failures)[p];
    failure.clear();
    if (!workers_[t]) workers_[t] = std::make_unique<Worker>();
    Worker& w = *workers_[t];
    if (!w.solver) {
      w.solver = std::make_unique<QuasistaticSolver>(physics, PoseBoundaryConditions(*model, 0),
                                                     solver_options);
      w.springs = std::make_unique<EmbeddedAttachments>(model->embedding, model->mesh.tets,
                                                        stiffness_, model->mesh.vertices);
      w.solver->AddEnergyTerm(w.springs.get());
      w.start_factor = RestStiffnessFactor(model->mesh.vertices, w.solver.get());
    }
    // Each pose starts from the same factor, not from the one the pose this worker solved
    // before left (which its Newton steps would reuse): a pose's target then depends on
    // nothing but the pose, whichever thread or rank solves it, in whatever order, and in
    // a resumed run.
    StartFromFactor(w.start_factor, w.solver.get());
    const BoundaryConditions bc = PoseBoundaryConditions(*model, p);
    const Eigen::Matrix3Xd rest_fixed =
        ModelBoundaryConditions(*model, RestBoneTransforms(*model)).positions;
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
    pose.target.resize(6, 0);
    if (!report.converged) {
      failure = "pose '" + pose.name + "': the embedded simulation did not converge: " +
                report.Summary();
      if (!w.solver->positions().allFinite()) {
        // No target (pose.target has no columns), and no surface error to record (0, not
        // an earlier call's; the summary leaves such poses out).
        pose.embedding_mean_error = pose.embedding_max_error = 0.0;
        std::lock_guard<std::mutex> lock(log_mutex);
        log << "  " << std::left << std::setw(22) << pose.name << std::right
            << " no target: the embedded simulation ended in a state that is not finite ("
            << report.Summary() << ")\n"
            << std::flush;
        return;
      }
    }
    const Eigen::Matrix3Xd x = w.solver->positions();
    pose.target.resize(6, physics.num_elements());
    int inverted = 0;  // elements inverted at x
    double lowest_det = std::numeric_limits<double>::infinity();
    for (int e = 0; e < physics.num_elements(); ++e) {
      const Eigen::Matrix3d f = physics.DeformationGradient(x, e);
      pose.target.col(e) = ElementTarget(f, options.inverted_targets);
      const double det = f.determinant();
      if (det <= 0) ++inverted;
      lowest_det = std::min(lowest_det, det);
    }
    const Eigen::VectorXd distance = (w.springs->Points(x) - pose.surface).colwise().norm();
    pose.embedding_mean_error = distance.mean();
    pose.embedding_max_error = distance.maxCoeff();
    std::string store_error;
    const bool stored = store == nullptr || store->Save(p, pose, failure, &store_error);
    std::lock_guard<std::mutex> lock(log_mutex);
    if (!stored) log << "  warning: pose '" << pose.name << "' not kept: " << store_error << "\n";
    log << "  " << std::left << std::setw(22) << pose.name << std::right << " surface error mean "
        << std::setprecision(3) << pose.embedding_mean_error << " max " << pose.embedding_max_error
        << " (pose moves up to "
        << (pose.surface - model->neutral.vertices).colwise().norm().maxCoeff() << "), "
        << report.Path()
        << (steps > 1 ? " in " + std::to_string(steps) + " steps" : std::string()) << ", "
        << timer.Seconds() << " s" << (report.converged ? "" : ", NOT CONVERGED");
    if (inverted > 0) {
      log << "; " << inverted << " element(s) inverted (lowest det F " << lowest_det << ")"
          << (options.inverted_targets == InvertedTargets::kMirror
                  ? ": their targets are mirror images (--bone_clearance may help)"
                  : ", their targets inverted too");
    }
    log << "\n"
        << std::flush;
  }, 1);
}

bool MakeVolumetricTargets(const VolumetricTargetOptions& options, ActiveModel* model,
                           std::ostream& log, std::string* error,
                           std::vector<std::string>* unconverged) {
  if (!options.Validate(error)) return false;
  const int num_poses = model->num_poses();
  std::vector<std::string> failures(num_poses);
  TargetStore store;
  const bool storing = !options.store_directory.empty();
  if (storing &&
      !store.Open(options.store_directory, TargetStoreKey(options, *model), error)) {
    return false;
  }
  std::vector<int> remaining;
  for (int p = 0; p < num_poses; ++p) {
    if (!storing || !store.Load(p, model->mesh.num_tets(), &model->poses[p], &failures[p])) {
      remaining.push_back(p);
    }
  }
  if (remaining.size() < static_cast<size_t>(num_poses)) {
    log << "  " << num_poses - remaining.size() << " of " << num_poses
        << " poses' targets were taken from " << options.store_directory
        << " (an earlier run of the same preparation)\n";
  }
  MakeVolumetricTargetsOf(options, remaining, storing ? &store : nullptr, model, log, &failures);
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
