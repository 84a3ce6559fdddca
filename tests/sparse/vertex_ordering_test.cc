#include "sparse/vertex_ordering.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "physics/boundary_conditions.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

TEST(VertexOrderingTest, IsAPermutationOfTheFreeVertices) {
  const TetMesh mesh = testing::BarMesh(6, 4, 3, 0.5);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  const std::vector<bool> fixed = FixedVertexMask(bc, mesh.num_vertices());
  std::vector<int> order = FillReducingVertexOrder(mesh.tets, fixed);
  ASSERT_EQ(order.size(), mesh.num_vertices() - bc.vertices.size());
  std::sort(order.begin(), order.end());
  EXPECT_TRUE(std::adjacent_find(order.begin(), order.end()) == order.end());
  for (int v : order) EXPECT_FALSE(fixed[v]);
}

TEST(VertexOrderingTest, AllFixedGivesEmptyOrder) {
  const TetMesh mesh = testing::BarMesh(1, 1, 1, 1.0);
  EXPECT_TRUE(FillReducingVertexOrder(mesh.tets, std::vector<bool>(mesh.num_vertices(), true))
                  .empty());
}

}  // namespace
}  // namespace aqs
