#include "testing/synthetic_muscles.h"

#include <random>

#include <glog/logging.h>

#include "equilibrium/quasistatic_solver.h"
#include "geometry/embedding.h"
#include "mesh/boundary_surface.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace testing {
namespace {

ActuationMatrix MuscleActuation(const TetMesh& mesh, const Eigen::Vector3d& m) {
  const Eigen::Vector3d lo = mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = mesh.vertices.rowwise().maxCoeff();
  const Eigen::Vector3d mid = 0.5 * (lo + hi);
  const Eigen::Vector3d along = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1, 1, 0).normalized();
  ActuationMatrix a = IdentityActuations(mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
    Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
    auto add = [&](double activation, const Eigen::Vector3d& f) {
      const Eigen::Matrix3d ff = f * f.transpose();
      s += -activation * ff + 0.5 * activation * (Eigen::Matrix3d::Identity() - ff);
    };
    if (c.y() > mid.y()) add(m[0], along);
    if (c.y() < mid.y()) add(m[1], along);
    if (c.z() > mid.z()) add(m[2], diagonal);
    a.col(e) = ActuationFromSymmetric(s);
  }
  return a;
}

}  // namespace

SyntheticMuscles MakeSyntheticMuscles(int num_train, int num_test, double max_activation,
                                      unsigned seed) {
  SyntheticMuscles out;
  ActiveModel& model = out.model;
  model.mesh = BarMesh(10, 2, 2, 0.2);
  model.mu = Eigen::VectorXd::Ones(model.mesh.num_tets());
  const BoundaryConditions bc = LeftFaceFixed(model.mesh);
  model.static_vertices = bc.vertices;
  const BoundarySurface boundary = ExtractBoundarySurface(model.mesh);
  model.neutral = BoundaryToSurface(boundary, model.mesh.vertices);
  model.embedding = EmbedPoints(model.mesh, model.neutral.vertices, 1);

  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolverOptions options;
  options.relative_force_tolerance = 1e-10;
  QuasistaticSolver solver(physics, bc, options);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, max_activation);
  for (int i = 0; i < num_train + num_test; ++i) {
    const Eigen::Vector3d m(uniform(rng), uniform(rng), uniform(rng));
    solver.actuation() = MuscleActuation(model.mesh, m);
    solver.SetPositions(model.mesh.vertices);
    const QuasistaticSolveReport report = solver.Solve();
    CHECK(report.converged) << report.Summary();
    const Eigen::Matrix3Xd surface =
        EmbeddedPositions(model.embedding, model.mesh.tets, solver.positions());
    if (i < num_train) {
      TrainingPose pose;
      pose.name = "train_" + std::to_string(i);
      pose.surface = surface;
      model.poses.push_back(pose);
      out.train_activations.push_back(m);
    } else {
      out.test_surfaces.push_back(surface);
      out.test_activations.push_back(m);
    }
  }
  return out;
}

}  // namespace testing
}  // namespace aqs
