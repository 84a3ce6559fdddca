#include "testing/contact_scenes.h"

#include <string>

#include <glog/logging.h>

#include "equilibrium/quasistatic_solver.h"
#include "geometry/embedding.h"
#include "geometry/surface_tet_mesher.h"
#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace testing {

PointStencil Stencil(int first, const Eigen::Vector4d& w) {
  PointStencil s;
  for (int j = 0; j < 4; ++j) {
    s.vertex[j] = first + j;
    s.weight[j] = w[j];
  }
  s.offset = Eigen::Vector3d(0.01, -0.02, 0.03);
  return s;
}

void BoxSurface(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Matrix3Xd* v,
                Eigen::Matrix3Xi* t) {
  LatticeOptions options;
  options.origin = lo;
  options.spacing = 1.0;
  TetMesh cube = MakeLatticeMesh(options);  // one unit cube
  for (int i = 0; i < cube.num_vertices(); ++i) {
    cube.vertices.col(i) = lo + (hi - lo).cwiseProduct(cube.vertices.col(i) - lo);
  }
  const BoundarySurface boundary = ExtractBoundarySurface(cube);
  *v = cube.vertices;
  *t = boundary.triangles;
}

void NotchedPrismSurface(double depth, Eigen::Matrix3Xd* v, Eigen::Matrix3Xi* t) {
  const double profile[5][2] = {{-1, -2}, {1, -2}, {1, 0}, {0, -depth}, {-1, 0}};  // CCW
  v->resize(3, 10);
  for (int i = 0; i < 5; ++i) {
    v->col(i) << profile[i][0], profile[i][1], -1.0;
    v->col(i + 5) << profile[i][0], profile[i][1], 1.0;
  }
  t->resize(3, 16);
  int n = 0;
  for (int i = 0; i < 5; ++i) {  // the sides, outward for a counter-clockwise profile
    const int j = (i + 1) % 5;
    t->col(n++) << i, j, j + 5;
    t->col(n++) << i, j + 5, i + 5;
  }
  const int caps[3][3] = {{0, 1, 3}, {1, 2, 3}, {0, 3, 4}};  // counter-clockwise in (x, y)
  for (const auto& c : caps) {
    t->col(n++) << c[0] + 5, c[1] + 5, c[2] + 5;  // top cap, normal +z
    t->col(n++) << c[0], c[2], c[1];              // bottom cap, normal -z
  }
}

ActiveModel BlockModel(const TetMesh& mesh, const std::vector<int>& fixed) {
  ActiveModel model;
  model.mesh = mesh;
  model.mu = Eigen::VectorXd::Ones(mesh.num_tets());
  model.static_vertices = fixed;
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  model.neutral.vertices = mesh.vertices;  // all vertices; only boundary ones are in triangles
  model.neutral.triangles = boundary.triangles;
  model.embedding = EmbedPoints(mesh, mesh.vertices, 1);
  return model;
}

bool ContactFreeEquilibrium(const ActiveModel& model, const RigidTransform& push,
                            Eigen::Matrix3Xd* positions) {
  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolver solver(physics, ModelBoundaryConditions(model, {push}));
  const bool converged = solver.Solve().converged;
  *positions = solver.positions();
  return converged;
}

ActiveModel TwoBallsModel(int* surface_vertices_per_ball) {
  const SurfaceMesh left_sphere = Icosphere(3, 0.5, Eigen::Vector3d(0, 0, 0));
  const SurfaceMesh right_sphere = Icosphere(3, 0.5, Eigen::Vector3d(1.1, 0, 0));
  SurfaceTetMeshOptions meshing;
  meshing.spacing = 0.2;
  TetMesh left_mesh, right_mesh;
  std::string error;
  CHECK(MeshSurfaceInterior(left_sphere.vertices, left_sphere.triangles, meshing, &left_mesh,
                            &error)) << error;
  CHECK(MeshSurfaceInterior(right_sphere.vertices, right_sphere.triangles, meshing, &right_mesh,
                            &error)) << error;
  ActiveModel model;
  model.mesh.vertices.resize(3, left_mesh.num_vertices() + right_mesh.num_vertices());
  model.mesh.vertices << left_mesh.vertices, right_mesh.vertices;
  model.mesh.tets.resize(4, left_mesh.num_tets() + right_mesh.num_tets());
  model.mesh.tets << left_mesh.tets, (right_mesh.tets.array() + left_mesh.num_vertices()).matrix();
  model.mu = Eigen::VectorXd::Ones(model.mesh.num_tets());
  const int ns = left_sphere.num_vertices();
  model.neutral.vertices.resize(3, 2 * ns);
  model.neutral.vertices << left_sphere.vertices, right_sphere.vertices;
  model.neutral.triangles.resize(3, 2 * left_sphere.num_triangles());
  model.neutral.triangles << left_sphere.triangles, (right_sphere.triangles.array() + ns).matrix();
  model.embedding = EmbedPoints(model.mesh, model.neutral.vertices, 2);
  Bone driver;
  driver.name = "driver";
  for (int v = 0; v < model.mesh.num_vertices(); ++v) {
    if (model.mesh.vertices(0, v) < -0.3) model.static_vertices.push_back(v);
    if (model.mesh.vertices(0, v) > 1.4) driver.vertices.push_back(v);
  }
  model.bones = {driver};
  *surface_vertices_per_ball = ns;
  return model;
}

ContactOptions BallsContactOptions(double max_depth) {
  ContactOptions options;
  options.thickness = 0.01;
  options.search_radius = 0.1;
  options.max_depth = max_depth;
  return options;
}

double BallsGap(const PushedBalls& balls, const Eigen::Matrix3Xd& state) {
  const int ns = balls.surface_vertices_per_ball;
  const Eigen::Matrix3Xd surface =
      EmbeddedPositions(balls.model.embedding, balls.model.mesh.tets, state);
  return surface.rightCols(ns).row(0).minCoeff() - surface.leftCols(ns).row(0).maxCoeff();
}

bool PushBalls(double distance, PushedBalls* balls) {
  balls->model = TwoBallsModel(&balls->surface_vertices_per_ball);
  balls->push.translation = Eigen::Vector3d(-distance, 0, 0);
  return ContactFreeEquilibrium(balls->model, balls->push, &balls->free);
}

}  // namespace testing
}  // namespace aqs
