#include "testing/test_meshes.h"

#include <cmath>

#include <Eigen/Geometry>

#include "mesh/lattice.h"

namespace aqs {
namespace testing {

TetMesh BarMesh(int nx, int ny, int nz, double spacing) {
  LatticeOptions options;
  options.nx = nx;
  options.ny = ny;
  options.nz = nz;
  options.spacing = spacing;
  options.type = LatticeType::kKuhn;
  return MakeLatticeMesh(options);
}

BoundaryConditions LeftFaceFixed(const TetMesh& mesh, double tolerance) {
  BoundaryConditions bc;
  const double min_x = mesh.vertices.row(0).minCoeff();
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) <= min_x + tolerance) bc.vertices.push_back(v);
  }
  return bc;
}

ActuationMatrix SmoothActuation(const TetMesh& mesh, double amplitude) {
  const Eigen::Vector3d lo = mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = mesh.vertices.rowwise().maxCoeff();
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-12);
  ActuationMatrix a(6, mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
    const Eigen::Vector3d u = (c - lo).cwiseQuotient(extent);  // in [0, 1]^3
    const double theta = 0.8 * u.x() + 0.5 * u.z();
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(theta, Eigen::Vector3d(0.2, 1.0, 0.3).normalized()).toRotationMatrix();
    const Eigen::Vector3d stretch(1.0 - amplitude * std::sin(M_PI * u.x()),
                                  1.0 + 0.5 * amplitude * std::cos(2 * M_PI * u.y()),
                                  1.0 + 0.3 * amplitude * u.z());
    a.col(e) = ActuationFromSymmetric(r * stretch.asDiagonal() * r.transpose());
  }
  return a;
}

ActuationMatrix RandomActuation(int num_elements, double amplitude, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-amplitude, amplitude);
  ActuationMatrix a = IdentityActuations(num_elements);
  for (int i = 0; i < a.size(); ++i) a.data()[i] += uniform(*rng);
  return a;
}

}  // namespace testing
}  // namespace aqs
