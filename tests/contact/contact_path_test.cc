// ContactSolver::Resolve on small scenes: a block pushed into a slab, two balls pressed
// together and pushed through each other, crossed ridges (contact_path.cc, and the
// candidates and report it uses).

#include "contact/contact_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "geometry/distance/edge_distance.h"
#include "geometry/distance/triangle_distance.h"
#include "mesh/lattice.h"
#include "physics/actuation.h"
#include "testing/contact_scenes.h"

namespace aqs {
namespace {

using testing::BallsContactOptions;
using testing::BallsGap;
using testing::BlockModel;
using testing::BoxSurface;
using testing::ContactFreeEquilibrium;
using testing::PushBalls;
using testing::PushedBalls;

// [0, 1]^3 as a Kuhn lattice of 3 x 3 x 3 cubes.
TetMesh UnitBlock() {
  LatticeOptions lattice;
  lattice.nx = 3;
  lattice.ny = 3;
  lattice.nz = 3;
  lattice.spacing = 1.0 / 3.0;
  lattice.type = LatticeType::kKuhn;
  return MakeLatticeMesh(lattice);
}

TEST(ContactSolverTest, BlockPushedIntoASlabStopsAtItsSurface) {
  const TetMesh block = UnitBlock();
  std::vector<int> top;
  for (int v = 0; v < block.num_vertices(); ++v) {
    if (block.vertices(1, v) > 1 - 1e-9) top.push_back(v);
  }
  ActiveModel model = BlockModel(block, top);
  // Push the top down by 0.4: the block's bottom would reach y = -0.4 inside the slab
  // below y = -0.2.
  Bone lid;
  lid.name = "lid";
  lid.vertices = top;
  model.static_vertices.clear();
  model.bones = {lid};
  RigidTransform push;
  push.translation = Eigen::Vector3d(0, -0.4, 0);
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(ContactFreeEquilibrium(model, push, &free));
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  BoxSurface(Eigen::Vector3d(-1, -2, -1), Eigen::Vector3d(2, -0.2, 2), &v, &t);
  MovingObstacle slab;
  slab.name = "slab";
  slab.vertices = v;
  slab.triangles = t;
  ContactOptions options;
  options.thickness = 0.02;
  options.relative_stiffness = 1000.0;
  options.self_contact = false;
  options.solver.relative_force_tolerance = 1e-8;
  ContactSolver solver(model, options);
  Eigen::Matrix3Xd state;
  ContactReport report;
  std::string error;
  ASSERT_TRUE(solver.Resolve(IdentityActuations(block.num_tets()), {push}, {slab},
                             free, &state, &report, &error))
      << error;
  EXPECT_GT(report.before.max_penetration, 0.15) << report.Summary();
  EXPECT_GT(report.before.penetrating_points, 0);
  EXPECT_EQ(report.after.penetrating_points, 0) << report.Summary();
  EXPECT_EQ(report.after.obstacle_intersections, 0) << report.Summary();
  // The bottom rests on the slab, within the contact thickness.
  const double lowest = state.row(1).minCoeff();
  EXPECT_GE(lowest, -0.2 - 1e-9);
  EXPECT_LE(lowest, -0.2 + options.thickness);
  EXPECT_GT(report.obstacle_contacts, 0);
  // A NaN actuation is refused, not reported as success at the start (the embedder's
  // review); one of another mesh's size is a programmer error, not read past its end.
  ActuationMatrix nan = IdentityActuations(block.num_tets());
  nan(2, 1) = std::nan("");
  ContactReport refused;
  EXPECT_FALSE(solver.Resolve(nan, {push}, {slab}, free, &state, &refused, &error));
  EXPECT_NE(error.find("the actuation of element 1 is not finite"), std::string::npos) << error;
  EXPECT_DEATH(solver.Resolve(IdentityActuations(block.num_tets() - 1), {push}, {slab}, free,
                              &state, &refused, &error),
               "Resolve: the actuation has [0-9]+ columns, the model [0-9]+ elements");
  EXPECT_DEATH(solver.Resolve(IdentityActuations(block.num_tets()), {push}, {slab},
                              Eigen::Matrix3Xd::Zero(3, 5), &state, &refused, &error),
               "Resolve: the start has 5 vertices, the model's mesh [0-9]+");
}

// An obstacle that moves with a bone through a face whose vertices are all fixed: a
// crossing no contact can prevent. Halving stops at the shortest step (1 / (path_steps
// 2^max_step_halvings)) however often the crossing comes back, so the path takes a
// bounded number of tries (halving per accepted step let the steps shrink toward the
// crossing geometrically: 145 tries for 8 steps on the demo face).
TEST(ContactSolverTest, APathThroughAnUnavoidableCrossingTakesBoundedSteps) {
  const TetMesh block = UnitBlock();
  std::vector<int> top, bottom;
  for (int v = 0; v < block.num_vertices(); ++v) {
    if (block.vertices(1, v) > 1 - 1e-9) top.push_back(v);
    if (block.vertices(1, v) < 1e-9) bottom.push_back(v);
  }
  ActiveModel model = BlockModel(block, bottom);
  Bone lid;
  lid.name = "lid";
  lid.vertices = top;
  model.bones = {lid};
  // The lid pulled up by 0.4, and with it a plate below the fixed bottom, which it
  // carries up through the bottom face at t = 0.0437 / 0.4.
  RigidTransform pull;
  pull.translation = Eigen::Vector3d(0, 0.4, 0);
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(ContactFreeEquilibrium(model, pull, &free));
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  BoxSurface(Eigen::Vector3d(0.2, -0.6, 0.2), Eigen::Vector3d(0.8, -0.0437, 0.8), &v, &t);
  MovingObstacle plate;
  plate.name = "plate";
  plate.vertices = v;
  plate.triangles = t;
  plate.bone = 0;
  ContactOptions options;
  options.thickness = 0.02;
  options.self_contact = false;
  options.path_steps = 4;
  options.max_step_halvings = 3;
  options.max_rounds = 1;
  ContactSolver solver(model, options);
  Eigen::Matrix3Xd state;
  ContactReport report;
  std::string error;
  ASSERT_TRUE(solver.Resolve(IdentityActuations(block.num_tets()), {pull}, {plate}, free,
                             &state, &report, &error))
      << error;
  std::printf("path: %d steps, %d halvings\n", report.path_steps, report.path_halvings);
  EXPECT_GT(report.after.obstacle_intersections, 0) << "the crossing is unavoidable";
  EXPECT_GT(report.path_halvings, 0);
  // Every step taken is at least 1/32 long, and each is tried at most 4 times.
  EXPECT_LE(report.path_steps, 32);
  EXPECT_LE(report.path_steps + report.path_halvings, 4 * 32);
  // In fact a crossing costs a few tries more than the plain path's 4 steps.
  EXPECT_LE(report.path_steps + report.path_halvings, 4 + 4 * 3 + 8);
}

TEST(ContactSolverTest, TwoSpheresPressedTogetherFlattenWithoutIntersecting) {
  // The right ball pushed 0.3 towards the left one (0.1 gap: 0.2 of overlap without
  // contact).
  PushedBalls balls;
  ASSERT_TRUE(PushBalls(0.3, &balls));
  const ActiveModel& model = balls.model;
  ContactOptions options = BallsContactOptions(0.4);
  for (int path_steps : {0, 8}) {
    options.path_steps = path_steps;
    ContactSolver solver(model, options);
    Eigen::Matrix3Xd state;
    ContactReport report;
    std::string error;
    ASSERT_TRUE(solver.Resolve(IdentityActuations(model.mesh.num_tets()), {balls.push}, {},
                               balls.free, &state, &report, &error))
        << error;
    EXPECT_GT(report.before.self_intersections.all, 50) << report.Summary();
    EXPECT_EQ(report.after.self_intersections.all, 0) << report.Summary();
    EXPECT_GT(report.self_contacts, 0) << report.Summary();
    EXPECT_TRUE(report.converged) << report.Summary();
    EXPECT_EQ(report.path_steps, path_steps) << report.Summary();
    // The spheres meet flattened: along the centre line, the right sphere's leftmost
    // point is within the thickness of the left sphere's rightmost one, not behind it.
    const double gap = BallsGap(balls, state);
    EXPECT_GE(gap, -0.01) << report.Summary();
    EXPECT_LE(gap, 3 * options.thickness) << report.Summary();
    // The far sides stay where they were held.
    EXPECT_LT(report.max_far_displacement, 0.05) << report.Summary();
  }
}

TEST(ContactSolverTest, SpheresPushedThroughEachOtherAreSeparatedAlongThePath) {
  // The right ball pushed 0.45 towards the left one: without contact its front passes
  // 0.35 through the left ball, deeper than max_depth (0.25), so rounds that start there
  // cannot tell the sides; the path from rest catches the contact as it begins.
  PushedBalls balls;
  ASSERT_TRUE(PushBalls(0.45, &balls));
  const ActiveModel& model = balls.model;
  ContactOptions options = BallsContactOptions(0.25);
  options.path_steps = 0;
  // (Point-triangle pairs only: edge-edge pairs keep the sides of rest without a path
  // and would separate these balls, whose edges cross shallowly.)
  options.edge_contact = false;
  ContactReport direct, path;
  Eigen::Matrix3Xd state;
  std::string error;
  ASSERT_TRUE(ContactSolver(model, options)
                  .Resolve(IdentityActuations(model.mesh.num_tets()), {balls.push}, {}, balls.free,
                           &state, &direct, &error))
      << error;
  EXPECT_GT(direct.after.self_intersections.all, 20) << direct.Summary();
  options.path_steps = 8;
  options.edge_contact = true;
  ASSERT_TRUE(ContactSolver(model, options)
                  .Resolve(IdentityActuations(model.mesh.num_tets()), {balls.push}, {}, balls.free,
                           &state, &path, &error))
      << error;
  EXPECT_GT(path.before.self_intersections.all, 100) << path.Summary();
  EXPECT_EQ(path.after.self_intersections.all, 0) << path.Summary();
  EXPECT_TRUE(path.converged) << path.Summary();
  EXPECT_GE(path.path_steps, 8);
  const double gap = BallsGap(balls, state);
  EXPECT_GE(gap, -0.01) << path.Summary();
  EXPECT_LE(gap, 3 * options.thickness) << path.Summary();
}

// Two unit cubes, each a 2 x 2 x 2 lattice turned 45 degrees to present an edge: the
// lower one's ridge along x (held at its bottom), the upper one's along y above it
// (driven at its top by bone "driver"), 0.1 apart where they cross. Both ridges cross
// in the middle of an edge, so that no vertex meets a face when the upper cube is
// pushed down by less than about 0.25 beyond touching: an edge-edge contact.
ActiveModel CrossedRidgesModel() {
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.5;
  lattice.origin = Eigen::Vector3d(-0.5, -0.5, -0.5);
  const TetMesh cube = MakeLatticeMesh(lattice);
  const double ridge = std::sqrt(0.5);  // half the cube's face diagonal
  const Eigen::Matrix3d lower_turn =
      Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d upper_turn =
      Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  TetMesh mesh;
  const int n = cube.num_vertices();
  mesh.vertices.resize(3, 2 * n);
  mesh.vertices.leftCols(n) = lower_turn * cube.vertices;
  mesh.vertices.rightCols(n) =
      (upper_turn * cube.vertices).colwise() + Eigen::Vector3d(0.25, 0.25, 2 * ridge + 0.1);
  mesh.tets.resize(4, 2 * cube.num_tets());
  mesh.tets << cube.tets, (cube.tets.array() + n).matrix();
  std::vector<int> held;
  Bone driver;
  driver.name = "driver";
  for (int v = 0; v < 2 * n; ++v) {
    if (v < n && mesh.vertices(2, v) < -ridge + 1e-9) held.push_back(v);
    if (v >= n && mesh.vertices(2, v) > 3 * ridge + 0.1 - 1e-9) driver.vertices.push_back(v);
  }
  ActiveModel model = BlockModel(mesh, held);
  model.bones = {driver};
  return model;
}

TEST(ContactSolverTest, CrossedRidgesStopAtTheirEdgesWithEdgeEdgePairs) {
  const ActiveModel model = CrossedRidgesModel();
  RigidTransform push;
  push.translation = Eigen::Vector3d(0, 0, -0.25);  // the ridges overlap by 0.15
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(ContactFreeEquilibrium(model, push, &free));
  ContactOptions options;
  options.thickness = 0.01;
  options.search_radius = 0.1;
  options.max_depth = 0.3;
  options.exclusion_rings = 1;
  // The crossing ridge edges: the lower one from (0, 0, r) to (0.5, 0, r), the upper one
  // from (0.25, -0.25, r + 0.1) to (0.25, 0.25, r + 0.1) at rest (r = sqrt(1/2)).
  const double r = std::sqrt(0.5);
  auto vertex_at = [&](const Eigen::Vector3d& p) {
    for (int v = 0; v < model.mesh.num_vertices(); ++v) {
      if ((model.mesh.vertices.col(v) - p).norm() < 1e-9) return v;
    }
    LOG(FATAL) << "no vertex at " << p.transpose();
    return -1;
  };
  const int lower[2] = {vertex_at(Eigen::Vector3d(0, 0, r)), vertex_at(Eigen::Vector3d(0.5, 0, r))};
  const int upper[2] = {vertex_at(Eigen::Vector3d(0.25, -0.25, r + 0.1)),
                        vertex_at(Eigen::Vector3d(0.25, 0.25, r + 0.1))};
  for (int path_steps : {0, 8}) {
    options.path_steps = path_steps;
    for (bool edge_contact : {false, true}) {
      options.edge_contact = edge_contact;
      Eigen::Matrix3Xd state;
      ContactReport report;
      std::string error;
      ASSERT_TRUE(ContactSolver(model, options)
                      .Resolve(IdentityActuations(model.mesh.num_tets()), {push}, {}, free,
                               &state, &report, &error))
          << error;
      EXPECT_GT(report.before.self_intersections.all, 0) << report.Summary();
      if (!edge_contact) {
        // Point-triangle pairs alone let the edges pass.
        EXPECT_GT(report.after.self_intersections.all, 0) << report.Summary();
        continue;
      }
      EXPECT_EQ(report.after.self_intersections.all, 0) << "path " << path_steps << ": "
                                                    << report.Summary();
      EXPECT_TRUE(report.converged) << report.Summary();
      // The crossing is unstable without friction: the soft cubes shear until the ridges
      // meet at their middle vertices (in both runs the closest points of the nearest
      // edge pair are within 1% of an end of each edge) or slide past each other. Never
      // do they pass through each other: over the two edges of each ridge, the nearest
      // pair is at least half the thickness apart (with 0 path steps they end 0.00999
      // apart, with 8 steps 0.032), the upper edge on the upper side of the lower one's
      // line (the sign of their lines' distance).
      const int lower_ridge[3] = {vertex_at(Eigen::Vector3d(-0.5, 0, r)), lower[0], lower[1]};
      const int upper_ridge[3] = {upper[0], upper[1],
                                  vertex_at(Eigen::Vector3d(0.25, 0.75, r + 0.1))};
      double nearest = std::numeric_limits<double>::infinity(), gap = 0.0;
      for (int i = 0; i < 2; ++i) {
        for (int j = 0; j < 2; ++j) {
          const Eigen::Vector3d a0 = state.col(lower_ridge[i]), a1 = state.col(lower_ridge[i + 1]);
          const Eigen::Vector3d b0 = state.col(upper_ridge[j]), b1 = state.col(upper_ridge[j + 1]);
          const double distance = SegmentSegmentDistance(a0, a1, b0, b1);
          double s = 0, u = 0, w = 0;
          ASSERT_TRUE(EdgeDistance(a0, a1, b0, b1, kMinEdgeSine, &s, nullptr, &u, &w));
          if (distance < nearest) {
            nearest = distance;
            gap = -s;
          }
        }
      }
      EXPECT_GE(nearest, 0.5 * options.thickness) << "path " << path_steps << "; "
                                                  << report.Summary();
      EXPECT_GT(gap, 0.0) << "path " << path_steps << ": the upper ridge's edge is below";
    }
  }
}

}  // namespace
}  // namespace aqs
