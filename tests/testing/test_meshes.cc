#include "testing/test_meshes.h"

#include <utility>

#include "mesh/lattice.h"
#include "physics/actuation_fields.h"

namespace aqs {
namespace testing {

TetMesh UnitTet() {
  TetMesh mesh;
  mesh.vertices.resize(3, 4);
  mesh.vertices << 0, 1, 0, 0,  //
      0, 0, 1, 0,               //
      0, 0, 0, 1;
  mesh.tets.resize(4, 1);
  mesh.tets << 0, 1, 2, 3;
  return mesh;
}

TetMesh JoinMeshes(const TetMesh& a, const TetMesh& b) {
  TetMesh joined;
  const int n = a.num_vertices(), m = a.num_tets();
  joined.vertices.resize(3, n + b.num_vertices());
  joined.vertices << a.vertices, b.vertices;
  joined.tets.resize(4, m + b.num_tets());
  joined.tets << a.tets, (b.tets.array() + n).matrix();
  const bool positive = SignedTetVolume(joined, joined.vertices, 0) > 0;
  for (int t = m; t < joined.num_tets(); ++t) {
    if ((SignedTetVolume(joined, joined.vertices, t) > 0) != positive) {
      std::swap(joined.tets(1, t), joined.tets(2, t));
    }
  }
  return joined;
}

TetMesh OneTetMesh() {
  TetMesh mesh;
  mesh.vertices.resize(3, 4);
  mesh.vertices << 0.1, 1.0, -0.05, 0.08,
                   -0.1, 0.05, 0.9, 0.02,
                   0.0, 0.1, -0.04, 1.1;
  mesh.tets.resize(4, 1);
  mesh.tets << 0, 1, 2, 3;
  return mesh;
}

TetMesh ThreeTetMesh() {
  TetMesh mesh;
  mesh.vertices.resize(3, 6);
  mesh.vertices << 0, 1, 0, 0, 1, 1.2,
                   0, 0, 1, 0, 1, -0.3,
                   0, 0, 0, 1, 1, 0.8;
  mesh.tets.resize(4, 3);
  mesh.tets << 0, 1, 1,
               1, 2, 3,
               2, 3, 0,
               3, 4, 5;
  return mesh;
}

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
  return SmoothFibreActuation(mesh, amplitude);
}

ActuationMatrix CurlActuation(const TetMesh& mesh, double amount) {
  ActuationMatrix a = IdentityActuations(mesh.num_tets());
  const double middle = 0.5 * (mesh.vertices.row(1).minCoeff() + mesh.vertices.row(1).maxCoeff());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    double y = 0;
    for (int k = 0; k < 4; ++k) y += 0.25 * mesh.vertices(1, mesh.tets(k, e));
    a(0, e) = y > middle ? 1.0 - amount : 1.0 + amount;
  }
  return a;
}

ActuationMatrix RandomActuation(int num_elements, double amplitude, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-amplitude, amplitude);
  ActuationMatrix a = IdentityActuations(num_elements);
  for (int i = 0; i < a.size(); ++i) a.data()[i] += uniform(*rng);
  return a;
}

Eigen::Matrix3Xd JitteredVertices(const TetMesh& mesh, double sigma, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, sigma);
  Eigen::Matrix3Xd x = mesh.vertices;
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += normal(*rng);
  return x;
}

void AppendLoneElement(TetMesh* mesh, double gap, double size) {
  const Eigen::Vector3d corner =
      mesh->vertices.rowwise().maxCoeff() + Eigen::Vector3d(0.0, 0.0, gap);
  TetMesh lone;
  lone.vertices.resize(3, 4);
  lone.vertices << corner, corner + Eigen::Vector3d(-size, 0.0, 0.0),
      corner + Eigen::Vector3d(0.0, -size, 0.0), corner + Eigen::Vector3d(0.0, 0.0, size);
  lone.tets.resize(4, 1);
  lone.tets << 0, 1, 2, 3;
  *mesh = JoinMeshes(*mesh, lone);
}

}  // namespace testing
}  // namespace aqs
