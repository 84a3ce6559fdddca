// ContactOffsets (contact/contact_offsets.h): the augmented-Lagrangian offsets of
// self-contact pairs, updated after a round and read by the next, on hand-made pairs.

#include "contact/contact_offsets.h"

#include <gtest/gtest.h>

namespace aqs {
namespace {

// A stencil that is vertex v of the state itself.
PointStencil At(int v) {
  PointStencil stencil;
  for (int j = 0; j < 4; ++j) {
    stencil.vertex[j] = v;
    stencil.weight[j] = j == 0 ? 1.0 : 0.0;
  }
  stencil.offset.setZero();
  return stencil;
}

SelfContactPair Pair(SelfContactPair::Kind kind, int point, int a, int b, int c) {
  SelfContactPair pair;
  pair.kind = kind;
  pair.point = At(point);
  pair.corner[0] = At(a);
  pair.corner[1] = At(b);
  pair.corner[2] = At(c);
  return pair;
}

// Its signed distance at x.
double DistanceOf(const SelfContactPair& pair, const Eigen::Matrix3Xd& x) {
  const Eigen::Vector3d points[4] = {pair.point.Position(x), pair.corner[0].Position(x),
                                     pair.corner[1].Position(x), pair.corner[2].Position(x)};
  double s = 0, outside = 0;
  EXPECT_TRUE(SelfContactDistance(pair, points, &s, nullptr, &outside));
  return s;
}

ContactOffsetRule Rule() {
  ContactOffsetRule rule;
  rule.thickness = 0.1;
  rule.max_depth = 0.2;
  rule.max_outside = 1e9;
  rule.max_offset = 0.25;
  return rule;
}

// A point-triangle pair pressed to 0.04 of its triangle: its vertex's offset grows by
// thickness - s each round until the cap; apart (s > thickness) it shrinks to 0; another
// pair of the same point reads the same offset.
TEST(ContactOffsetsTest, APointsOffsetGrowsWhilePressedAndStaysInItsRange) {
  Eigen::Matrix3Xd x(3, 5);
  x << 0.2, 0, 1, 0, 0.3,  //
      0.2, 0, 0, 1, 0.3,   //
      0.04, 0, 0, 0, 0.5;
  SelfContactPair pair = Pair(SelfContactPair::Kind::kPointTriangle, 0, 1, 2, 3);
  pair.surface_vertex = 2;
  ASSERT_NEAR(DistanceOf(pair, x), 0.04, 1e-12);
  ContactOffsets offsets(4);
  EXPECT_EQ(offsets.Of(pair), 0.0);
  ASSERT_TRUE(offsets.Update(pair, x, Rule()));
  EXPECT_NEAR(offsets.Of(pair), 0.06, 1e-12);
  ASSERT_TRUE(offsets.Update(pair, x, Rule()));
  EXPECT_NEAR(offsets.Of(pair), 0.12, 1e-12);
  for (int round = 0; round < 5; ++round) offsets.Update(pair, x, Rule());
  EXPECT_EQ(offsets.Of(pair), 0.25);
  // The same surface vertex against another triangle: the point's offset.
  SelfContactPair other = Pair(SelfContactPair::Kind::kPointTriangle, 4, 1, 2, 3);
  other.surface_vertex = 2;
  EXPECT_EQ(offsets.Of(other), 0.25);
  // Apart: 0.25 + 0.1 - 0.5 < 0.
  ASSERT_NEAR(DistanceOf(other, x), 0.5, 1e-12);
  ASSERT_TRUE(offsets.Update(other, x, Rule()));
  EXPECT_EQ(offsets.Of(pair), 0.0);
  // Another vertex was never touched.
  SelfContactPair third = pair;
  third.surface_vertex = 3;
  EXPECT_EQ(offsets.Of(third), 0.0);
}

// Two edge-edge pairs that share their first edge: the pressed one's offset grows, the
// one apart stays at 0, and updating the second does not clamp the first's (one offset
// per first edge did).
TEST(ContactOffsetsTest, EdgePairsKeepAnOffsetEachEvenWithAnEdgeInCommon) {
  Eigen::Matrix3Xd x(3, 6);
  x << -1, 1, 0, 0, 0.5, 0.5,  //
      0, 0, -1, 1, -1, 1,      //
      0.03, 0.03, 0, 0, -1, -1;
  SelfContactPair pressed = Pair(SelfContactPair::Kind::kEdgeEdge, 0, 1, 2, 3);
  pressed.edge = 3;
  pressed.second_edge = 7;
  SelfContactPair apart = Pair(SelfContactPair::Kind::kEdgeEdge, 0, 1, 4, 5);
  apart.edge = 3;
  apart.second_edge = 9;
  // The side each keeps: the one the first edge is on.
  if (DistanceOf(pressed, x) < 0) pressed.sign = -1.0;
  if (DistanceOf(apart, x) < 0) apart.sign = -1.0;
  ASSERT_NEAR(DistanceOf(pressed, x), 0.03, 1e-12);
  ASSERT_NEAR(DistanceOf(apart, x), 1.03, 1e-12);
  ContactOffsets offsets;
  ASSERT_TRUE(offsets.Update(pressed, x, Rule()));
  ASSERT_TRUE(offsets.Update(apart, x, Rule()));
  EXPECT_NEAR(offsets.Of(pressed), 0.07, 1e-12);
  EXPECT_EQ(offsets.Of(apart), 0.0);
  ASSERT_TRUE(offsets.Update(pressed, x, Rule()));
  EXPECT_NEAR(offsets.Of(pressed), 0.14, 1e-12);
  // A pair never updated starts at 0.
  SelfContactPair unseen = pressed;
  unseen.second_edge = 8;
  EXPECT_EQ(offsets.Of(unseen), 0.0);
}

// No update where the pair's distance is in doubt: deeper than max_depth, outside its
// feature by more than max_outside, or faded out (a flat triangle; nearly parallel
// edges).
TEST(ContactOffsetsTest, PairsInDoubtLeaveTheirOffsetAlone) {
  ContactOffsets offsets(1);
  Eigen::Matrix3Xd x(3, 4);
  x << 0.2, 0, 1, 0,  //
      0.2, 0, 0, 1,   //
      -0.5, 0, 0, 0;
  SelfContactPair deep = Pair(SelfContactPair::Kind::kPointTriangle, 0, 1, 2, 3);
  deep.surface_vertex = 0;
  EXPECT_FALSE(offsets.Update(deep, x, Rule()));
  EXPECT_EQ(offsets.Of(deep), 0.0);
  // Pressed, but its projection lies 1.8 outside the triangle.
  x.col(0) << 2.0, 2.0, 0.04;
  ContactOffsetRule rule = Rule();
  rule.max_outside = 0.5;
  EXPECT_FALSE(offsets.Update(deep, x, rule));
  EXPECT_TRUE(offsets.Update(deep, x, Rule()));
  EXPECT_NEAR(offsets.Of(deep), 0.06, 1e-12);
  // A triangle 0.001 high (quality ~0.0013, below its fade band's zero).
  Eigen::Matrix3Xd flat(3, 4);
  flat << 0.5, 0, 1, 0.5,  //
      0.0005, 0, 0, 0.001, //
      0.04, 0, 0, 0;
  EXPECT_FALSE(offsets.Update(deep, flat, Rule()));
  EXPECT_NEAR(offsets.Of(deep), 0.06, 1e-12);
  // Edges at a sine of 0.02 (below kEdgeFadeSine).
  Eigen::Matrix3Xd parallel(3, 4);
  parallel << -1, 1, -1, 1,  //
      0, 0, -0.02, 0.02,     //
      0.03, 0.03, 0, 0;
  SelfContactPair edges = Pair(SelfContactPair::Kind::kEdgeEdge, 0, 1, 2, 3);
  edges.edge = 0;
  edges.second_edge = 1;
  ContactOffsets edge_offsets;
  EXPECT_FALSE(edge_offsets.Update(edges, parallel, Rule()));
  edges.sign = -1.0;
  EXPECT_FALSE(edge_offsets.Update(edges, parallel, Rule()));
  EXPECT_EQ(edge_offsets.Of(edges), 0.0);
}

}  // namespace
}  // namespace aqs
