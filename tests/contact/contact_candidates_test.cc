// The contact candidates (ContactSolver::DetectSelfContacts and DetectEdgeContacts,
// contact/contact_candidates.cc) on two soft balls pressed together: every pair joins
// the two balls (none within one ball: exclusion rings and rest normals), points pair
// only with triangles within thickness + search radius, each with the stiffness of its
// points' surface springs, and balls apart have none; DetectObstacleContacts under a slab.

#include "contact/contact_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "contact/obstacle.h"
#include "geometry/distance/plane_distance.h"
#include "geometry/embedding.h"
#include "geometry/vertex_normals.h"
#include "model/surface_springs.h"
#include "testing/contact_scenes.h"

namespace aqs {
namespace {

// The surface vertex at position p (the closest one; corners are surface vertices).
int SurfaceVertexAt(const Eigen::Matrix3Xd& surface, const Eigen::Vector3d& p) {
  Eigen::Index closest = 0;
  (surface.colwise() - p).colwise().squaredNorm().minCoeff(&closest);
  return static_cast<int>(closest);
}

TEST(ContactCandidatesTest, PairsJoinTheTwoBallsWithinReach) {
  testing::PushedBalls balls;
  ASSERT_TRUE(testing::PushBalls(0.3, &balls));
  const ActiveModel& model = balls.model;
  const int per_ball = balls.surface_vertices_per_ball;
  const ContactOptions options = testing::BallsContactOptions(0.4);
  const ContactSolver contact(model, options);
  const Eigen::Matrix3Xd rest = EmbeddedPositions(model.embedding, model.mesh.tets,
                                                  model.mesh.vertices);
  const Eigen::Matrix3Xd pushed = EmbeddedPositions(model.embedding, model.mesh.tets, balls.free);
  auto ball = [per_ball](int surface_vertex) { return surface_vertex < per_ball ? 0 : 1; };
  const double reach = options.thickness + options.search_radius;

  const std::vector<SelfContactPair> pairs = contact.DetectSelfContacts(pushed);
  ASSERT_GT(pairs.size(), 20u);
  for (const SelfContactPair& pair : pairs) {
    ASSERT_EQ(pair.kind, SelfContactPair::Kind::kPointTriangle);
    const Eigen::Vector3d p = pair.point.Position(balls.free);
    Eigen::Vector3d c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = pair.corner[k].Position(balls.free);
      EXPECT_NE(ball(SurfaceVertexAt(pushed, c[k])), ball(pair.surface_vertex))
          << "point " << pair.surface_vertex << " paired within its own ball";
    }
    // In front of the triangle by less than thickness + search radius, or behind it by
    // less than max_depth (a point pushed into the other ball).
    const Eigen::Vector3d points[4] = {p, c[0], c[1], c[2]};
    double distance = 0.0, outside = 0.0;
    ASSERT_TRUE(SelfContactDistance(pair, points, &distance, nullptr, &outside));
    EXPECT_LT(distance, reach) << pair.surface_vertex;
    EXPECT_GT(distance, -options.max_depth) << pair.surface_vertex;
    EXPECT_LE(outside, options.margin + 1e-12) << pair.surface_vertex;
    EXPECT_GT(pair.stiffness, 0.0);
  }

  // And no point is missed: by brute force over the other ball's triangles, with the
  // rules DetectSelfContacts states (facing at rest, the projection within the margin,
  // -max_depth < s < thickness + search radius, outside at rest), every point that has
  // an eligible triangle has its pair, with the nearest one's distance.
  std::vector<int> pairs_of(pushed.cols(), 0);
  std::vector<double> paired_distance(pushed.cols(), 0.0);
  for (const SelfContactPair& pair : pairs) {
    const Eigen::Vector3d points[4] = {pair.point.Position(balls.free),
                                       pair.corner[0].Position(balls.free),
                                       pair.corner[1].Position(balls.free),
                                       pair.corner[2].Position(balls.free)};
    ++pairs_of[pair.surface_vertex];
    double distance = 0.0, outside = 0.0;
    SelfContactDistance(pair, points, &distance, nullptr, &outside);
    paired_distance[pair.surface_vertex] = std::abs(distance);
  }
  const Eigen::Matrix3Xi& triangles = model.neutral.triangles;
  const Eigen::Matrix3Xd rest_normals = VertexNormals(rest, triangles);
  int eligible_points = 0;
  for (int v = 0; v < pushed.cols(); ++v) {
    double nearest = std::numeric_limits<double>::infinity();
    for (int t = 0; t < triangles.cols(); ++t) {
      if (ball(triangles(0, t)) == ball(v)) continue;
      auto corner = [&](const Eigen::Matrix3Xd& x, int k) { return x.col(triangles(k, t)); };
      const Eigen::Vector3d normal =
          (corner(rest, 1) - corner(rest, 0)).cross(corner(rest, 2) - corner(rest, 0)).normalized();
      if (rest_normals.col(v).dot(normal) > options.max_normal_alignment) continue;
      double s = 0, s_rest = 0;
      Eigen::Vector3d beta, beta_rest;
      if (!PlaneDistance(pushed.col(v), corner(pushed, 0), corner(pushed, 1), corner(pushed, 2),
                         &s, nullptr, &beta) ||
          beta.minCoeff() < -options.margin || s <= -options.max_depth || s >= reach ||
          !PlaneDistance(rest.col(v), corner(rest, 0), corner(rest, 1), corner(rest, 2),
                         &s_rest, nullptr, &beta_rest) ||
          s_rest < -options.rest_tolerance) {
        continue;
      }
      nearest = std::min(nearest, std::abs(s));
    }
    if (!std::isfinite(nearest)) continue;
    ++eligible_points;
    EXPECT_EQ(pairs_of[v], 1) << "surface vertex " << v << " at " << nearest;
    if (pairs_of[v] == 1) {
      EXPECT_NEAR(paired_distance[v], nearest, 1e-12) << v;
    }
  }
  EXPECT_EQ(eligible_points, static_cast<int>(pairs.size()));

  const std::vector<SelfContactPair> edges = contact.DetectEdgeContacts(pushed, rest);
  EXPECT_FALSE(edges.empty());
  // Each pair names both its edges, the lower first, once: what the contact path keys
  // its augmented-Lagrangian offset by (one per first edge let a partner apart clamp a
  // pressed pair's offset to 0; that update itself is not run here). Here some edge has
  // two partners.
  std::set<std::pair<int, int>> keys;
  std::set<int> firsts;
  for (const SelfContactPair& pair : edges) {
    EXPECT_LT(pair.edge, pair.second_edge);
    EXPECT_TRUE(keys.insert({pair.edge, pair.second_edge}).second);
    firsts.insert(pair.edge);
  }
  EXPECT_LT(firsts.size(), keys.size());
  for (const SelfContactPair& pair : edges) {
    ASSERT_EQ(pair.kind, SelfContactPair::Kind::kEdgeEdge);
    const int first = contact.edges()(0, pair.edge);
    const Eigen::Vector3d other = pair.corner[1].Position(balls.free);
    EXPECT_NE(ball(first), ball(SurfaceVertexAt(pushed, other))) << "edge " << pair.edge;
    EXPECT_TRUE(pair.sign == 1.0 || pair.sign == -1.0);
  }

  // Each pair's stiffness: a point's own spring (SurfaceSpringStiffness), an edge pair's
  // the mean of its four ends'.
  const Eigen::VectorXd k = SurfaceSpringStiffness(model, options.relative_stiffness);
  for (const SelfContactPair& pair : pairs) {
    EXPECT_NEAR(pair.stiffness, k[pair.surface_vertex], 1e-12 * k[pair.surface_vertex]);
  }
  for (const SelfContactPair& pair : edges) {
    const Eigen::Matrix2Xi& e = contact.edges();
    const double mean = 0.25 * (k[e(0, pair.edge)] + k[e(1, pair.edge)] +
                                k[e(0, pair.second_edge)] + k[e(1, pair.second_edge)]);
    EXPECT_NEAR(pair.stiffness, mean, 1e-12 * mean) << "edges " << pair.edge << " "
                                                    << pair.second_edge;
  }

  // The right ball moved 2 away: nothing in reach.
  Eigen::Matrix3Xd apart = pushed;
  apart.rightCols(apart.cols() - per_ball).row(0).array() += 2.0;
  EXPECT_TRUE(contact.DetectSelfContacts(apart).empty());
  EXPECT_TRUE(contact.DetectEdgeContacts(apart, rest).empty());
}

// DetectObstacleContacts: under a slab whose top cuts into the pushed balls, the
// candidates are exactly the surface points within thickness + search radius of it
// (those inside it included), each once, with its own surface-spring stiffness.
TEST(ContactCandidatesTest, ObstacleCandidatesAreThePointsWithinReachWithTheirSprings) {
  testing::PushedBalls balls;
  ASSERT_TRUE(testing::PushBalls(0.3, &balls));
  const ActiveModel& model = balls.model;
  const ContactOptions options = testing::BallsContactOptions(0.4);
  const ContactSolver contact(model, options);
  const Eigen::Matrix3Xd pushed = EmbeddedPositions(model.embedding, model.mesh.tets, balls.free);
  const double top = pushed.row(1).minCoeff() + 0.05;
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(Eigen::Vector3d(-10, top - 5, -10), Eigen::Vector3d(10, top, 10), &v, &t);
  const Obstacle slab("slab", v, t);
  const ObstacleCandidates candidates = contact.DetectObstacleContacts(pushed, {&slab});
  const double reach = options.thickness + options.search_radius;
  std::vector<int> expected;
  for (int i = 0; i < pushed.cols(); ++i) {
    if (pushed(1, i) < top + reach) expected.push_back(i);
  }
  ASSERT_GT(expected.size(), 5u);
  ASSERT_LT(expected.size(), static_cast<size_t>(pushed.cols()));
  EXPECT_EQ(candidates.surface_vertices, expected);
  ASSERT_EQ(candidates.stiffness.size(), expected.size());
  ASSERT_EQ(candidates.points.size(), expected.size());
  const Eigen::VectorXd k = SurfaceSpringStiffness(model, options.relative_stiffness);
  for (size_t j = 0; j < expected.size(); ++j) {
    EXPECT_EQ(candidates.stiffness[j], k[expected[j]]) << "surface vertex " << expected[j];
    EXPECT_LT((candidates.points[j].Position(balls.free) - pushed.col(expected[j])).norm(),
              1e-12);
  }
  ContactOptions without = options;
  without.obstacle_contact = false;
  EXPECT_TRUE(ContactSolver(model, without).DetectObstacleContacts(pushed, {&slab})
                  .points.empty());
  // Only the surface vertices contact acts on (ContactOptions::surface_vertices,
  // --contact_vertices): here the left ball's.
  ContactOptions left = options;
  for (int i = 0; i < balls.surface_vertices_per_ball; ++i) left.surface_vertices.push_back(i);
  const ObstacleCandidates left_candidates =
      ContactSolver(model, left).DetectObstacleContacts(pushed, {&slab});
  EXPECT_FALSE(left_candidates.surface_vertices.empty());
  EXPECT_LT(left_candidates.surface_vertices.size(), expected.size());
  for (int i : left_candidates.surface_vertices) EXPECT_LT(i, balls.surface_vertices_per_ball);
}

}  // namespace
}  // namespace aqs
