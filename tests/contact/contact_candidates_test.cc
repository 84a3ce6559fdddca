// The contact candidates (ContactSolver::DetectSelfContacts and DetectEdgeContacts,
// contact/contact_candidates.cc) on two soft balls pressed together: every pair joins
// the two balls (none within one ball: exclusion rings and rest normals), points pair
// only with triangles within thickness + search radius, and balls apart have none.

#include "contact/contact_solver.h"

#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "geometry/embedding.h"
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

  // The right ball moved 2 away: nothing in reach.
  Eigen::Matrix3Xd apart = pushed;
  apart.rightCols(apart.cols() - per_ball).row(0).array() += 2.0;
  EXPECT_TRUE(contact.DetectSelfContacts(apart).empty());
  EXPECT_TRUE(contact.DetectEdgeContacts(apart, rest).empty());
}

}  // namespace
}  // namespace aqs
