// The report's measurements (ContactSolver::CountSelfIntersections, Measure) and its
// text (contact_report.cc).

#include "contact/contact_report.h"

#include <string>

#include <gtest/gtest.h>

#include "contact/contact_solver.h"
#include "contact/obstacle.h"
#include "geometry/embedding.h"
#include "mesh/lattice.h"
#include "testing/contact_scenes.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

using testing::BlockModel;

TEST(ContactMeasurementTest, CountsNewSelfIntersectionsByTheirRestState) {
  // A unit block whose embedded surface is six loose triangles: A (horizontal, facing up)
  // and B (vertical) crossing each other at rest, C and D (facing up) apart from
  // everything, E 0.01 above D (touching it, within rest_tolerance), F (facing down)
  // below A.
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.5;
  ActiveModel model = BlockModel(MakeLatticeMesh(lattice), {0});
  Eigen::Matrix3Xd rest(3, 18);
  rest << 0.2, 0.8, 0.5, 0.5, 0.5, 0.5, 0.1, 0.3, 0.2, 0.7, 0.9, 0.8, 0.7, 0.9, 0.8,  //
          0.1, 0.2, 0.3,                                                              //
          0.2, 0.2, 0.8, 0.4, 0.6, 0.5, 0.1, 0.1, 0.3, 0.1, 0.1, 0.3, 0.1, 0.1, 0.3,  //
          0.1, 0.3, 0.1,                                                              //
          0.5, 0.5, 0.5, 0.3, 0.3, 0.7, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.91, 0.91, 0.91,  //
          0.1, 0.1, 0.1;
  model.neutral.vertices = rest;
  model.neutral.triangles.resize(3, 6);
  model.neutral.triangles << 0, 3, 6, 9, 12, 15, 1, 4, 7, 10, 13, 16, 2, 5, 8, 11, 14, 17;
  model.embedding = EmbedPoints(model.mesh, rest, 1);
  ContactOptions options;
  options.exclusion_rings = 0;
  const ContactSolver solver(model, options);
  // The counts at a state, against all / new / separated / clean / facing.
  auto expect_counts = [&](const Eigen::Matrix3Xd& state, const std::string& what, int all,
                           int new_pairs, int separated, int clean, int facing) {
    const SelfIntersectionCounts counts = solver.CountSelfIntersections(state);
    EXPECT_EQ(counts.all, all) << what;
    EXPECT_EQ(counts.new_pairs, new_pairs) << what;
    EXPECT_EQ(counts.separated, separated) << what;
    EXPECT_EQ(counts.clean, clean) << what;
    EXPECT_EQ(counts.facing, facing) << what;
  };
  expect_counts(rest, "at rest", 1, 0, 0, 0, 0);
  // C moved through A (which intersects B at rest): new and apart at rest, not clean;
  // C and A both face up: a fold, not facing.
  Eigen::Matrix3Xd c_through_a = rest;
  c_through_a.middleCols(6, 3) << 0.3, 0.4, 0.35, 0.3, 0.3, 0.3, 0.4, 0.4, 0.6;
  expect_counts(c_through_a, "C through A", 2, 1, 1, 0, 0);
  // D moved through C (both clean at rest): new, apart at rest and clean.
  Eigen::Matrix3Xd d_through_c = rest;
  d_through_c.middleCols(9, 3) << 0.2, 0.25, 0.15, 0.2, 0.2, 0.2, 0.85, 0.95, 0.95;
  expect_counts(d_through_c, "D through C", 2, 1, 1, 1, 0);
  // E turned through D, which it touched at rest: new and clean, not separated.
  Eigen::Matrix3Xd e_through_d = rest;
  e_through_d.middleCols(12, 3) << 0.8, 0.85, 0.75, 0.2, 0.2, 0.2, 0.85, 0.95, 0.95;
  expect_counts(e_through_d, "E through D", 2, 1, 0, 1, 0);
  // F (facing down) tilted up through A (facing up, intersecting B at rest): new, apart
  // at rest, not clean, facing.
  Eigen::Matrix3Xd f_through_a = rest;
  f_through_a.middleCols(15, 3) << 0.25, 0.35, 0.45, 0.3, 0.45, 0.3, 0.4, 0.6, 0.6;
  expect_counts(f_through_a, "F through A", 2, 1, 1, 0, 1);

  // With a seventh triangle G joining A's first corner to F's first corner (and a new
  // vertex) and exclusion rings of 1, A's corner is within F's rings: F through A is a
  // fold, not facing.
  ActiveModel joined = BlockModel(MakeLatticeMesh(lattice), {0});
  Eigen::Matrix3Xd joined_rest(3, 19);
  joined_rest << rest, Eigen::Vector3d(0.05, 0.3, 0.3);
  joined.neutral.vertices = joined_rest;
  joined.neutral.triangles.resize(3, 7);
  joined.neutral.triangles << model.neutral.triangles, Eigen::Vector3i(0, 15, 18);
  joined.embedding = EmbedPoints(joined.mesh, joined_rest, 1);
  ContactOptions ringed = options;
  ringed.exclusion_rings = 1;
  const ContactSolver joined_solver(joined, ringed);
  Eigen::Matrix3Xd joined_f_through_a = joined_rest;
  joined_f_through_a.leftCols(18) = f_through_a;
  const SelfIntersectionCounts counts = joined_solver.CountSelfIntersections(joined_f_through_a);
  EXPECT_EQ(counts.separated, 1);
  EXPECT_EQ(counts.facing, 0);
}

// A point inside two overlapping obstacles (upper and lower teeth that overlap) is one
// penetrating point, as deep as the deeper of the two (it was counted once per obstacle).
TEST(ContactMeasurementTest, APointInsideTwoObstaclesCountsOnce) {
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.5;
  ActiveModel model = BlockModel(MakeLatticeMesh(lattice), {0});
  const ContactSolver solver(model, ContactOptions());
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(Eigen::Vector3d(0.2, 0.2, 0.2), Eigen::Vector3d(0.8, 0.8, 0.6), &v, &t);
  const Obstacle lower("lower", v, t);
  testing::BoxSurface(Eigen::Vector3d(0.2, 0.2, 0.5), Eigen::Vector3d(0.8, 0.8, 0.9), &v, &t);
  const Obstacle upper("upper", v, t);
  Eigen::Matrix3Xd surface = model.neutral.vertices.colwise() + Eigen::Vector3d(5, 0, 0);
  surface.col(0) = Eigen::Vector3d(0.5, 0.5, 0.55);  // 0.05 into lower, 0.05 into upper
  surface.col(1) = Eigen::Vector3d(0.5, 0.7, 0.3);   // 0.1 into lower
  double depth = 0.0;
  int points = 0;
  solver.MeasurePenetration(surface, {&lower, &upper}, &depth, &points);
  EXPECT_EQ(points, 2);
  EXPECT_NEAR(depth, 0.1, 1e-12);
}

TEST(ContactReportTest, TextNamesEveryMeasurementBeforeAndAfter) {
  ContactReport report;
  report.before.max_penetration = 0.25;
  report.after.max_penetration = 0.5;
  report.before.penetrating_points = 3;
  report.after.penetrating_points = 4;
  report.self_intersections_rest = 5;
  report.before.self_intersections = {6, 7, 8, 9, 21};
  report.after.self_intersections = {10, 11, 12, 13, 22};
  report.before.obstacle_intersections = 14;
  report.after.obstacle_intersections = 15;
  report.mean_displacement = 0.125;
  report.max_displacement = 1.5;
  report.far_distance = 2;
  report.max_far_displacement = 0.0625;
  report.rounds = 16;
  report.path_steps = 17;
  report.path_halvings = 18;
  report.obstacle_contacts = 19;
  report.self_contacts = 20;
  report.converged = false;
  report.round_summaries = {"round 1: it"};
  const std::string text = report.ToText();
  const std::string expected_values =
      "# round 1: it\n"
      "max_penetration_before 0.25\nmax_penetration_after 0.5\n"
      "penetrating_points_before 3\npenetrating_points_after 4\n"
      "self_intersections_rest 5\n"
      "self_intersections_before 6\nself_intersections_after 10\n"
      "new_self_intersections_before 7\nnew_self_intersections_after 11\n"
      "separated_self_intersections_before 8\nseparated_self_intersections_after 12\n"
      "clean_self_intersections_before 9\nclean_self_intersections_after 13\n"
      "facing_self_intersections_before 21\nfacing_self_intersections_after 22\n"
      "obstacle_intersections_before 14\nobstacle_intersections_after 15\n"
      "mean_displacement 0.125\nmax_displacement 1.5\nfar_distance 2\n"
      "max_far_displacement 0.0625\nrounds 16\npath_steps 17\npath_halvings 18\n"
      "obstacle_contacts 19\nself_contacts 20\nconverged 0\n";
  ASSERT_GE(text.size(), expected_values.size());
  EXPECT_EQ(text.substr(text.size() - expected_values.size()), expected_values) << text;
  EXPECT_EQ(text.rfind("# ActiveQS contact report: " + report.Summary() + "\n", 0), 0u) << text;
  EXPECT_EQ(report.Summary(),
            "penetration into obstacles: max 0.25 -> 0.5, points inside 3 -> 4; intersecting "
            "triangle pairs: self 6 -> 10 (5 at rest; not intersecting at rest 7 -> 11, of which "
            "apart at rest 8 -> 12 (facing each other 21 -> 22, the rest folds of one sheet), "
            "between triangles clean at rest 9 -> 13), with obstacles 14 "
            "-> 15; surface moved mean 0.125 max 1.5 (max 0.0625 farther than 2 from the "
            "contacts); 16 rounds over 17 path steps from rest (18 halved), 19 obstacle and 20 "
            "self contacts active; NOT CONVERGED");
}

// The exclusion rings are the vertices within that many edges of each surface vertex (by
// hop distances from a breadth-first search of the whole surface per vertex), and
// ContactOptions refuses more rings than kMaxExclusionRings.
TEST(ContactRingsTest, ExclusionRingsAreTheVerticesWithinThatManyEdges) {
  const ActiveModel model = BlockModel(testing::BarMesh(4, 3, 2, 0.25), {0});
  const int ns = model.num_surface_vertices();
  // The surface's edges (those of its triangles, as the solver lists them).
  std::vector<std::vector<int>> neighbours(ns);
  const ContactSolver edge_source(model, ContactOptions());
  const Eigen::Matrix2Xi& edges = edge_source.edges();
  for (Eigen::Index e = 0; e < edges.cols(); ++e) {
    neighbours[edges(0, e)].push_back(edges(1, e));
    neighbours[edges(1, e)].push_back(edges(0, e));
  }
  for (int rings : {0, 1, 2, 4}) {
    ContactOptions options;
    options.exclusion_rings = rings;
    const ContactSolver solver(model, options);
    for (int v = 0; v < ns; ++v) {
      if (neighbours[v].empty()) continue;  // not on a triangle
      std::vector<int> hops(ns, -1);
      std::vector<int> queue = {v};
      hops[v] = 0;
      for (size_t q = 0; q < queue.size(); ++q) {
        for (int w : neighbours[queue[q]]) {
          if (hops[w] < 0) {
            hops[w] = hops[queue[q]] + 1;
            queue.push_back(w);
          }
        }
      }
      std::vector<int> expected;
      for (int w = 0; w < ns; ++w) {
        if (hops[w] >= 0 && hops[w] <= rings) expected.push_back(w);
      }
      ASSERT_EQ(solver.ExclusionRing(v), expected) << "vertex " << v << ", rings " << rings;
    }
  }
  ContactOptions options;
  std::string error;
  options.exclusion_rings = kMaxExclusionRings;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.exclusion_rings = kMaxExclusionRings + 1;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("exclusion_rings"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
