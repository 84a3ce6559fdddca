#include "learn/grid_actuation_field.h"

#include <cmath>
#include <random>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// A 4 x 3 x 2 bar with jittered vertices, so that centroids fall at generic positions
// within their grid cells.
TetMesh JitteredBar() {
  TetMesh mesh = testing::BarMesh(4, 3, 2, 0.5);
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  for (int i = 0; i < mesh.vertices.size(); ++i) mesh.vertices.data()[i] += jitter(rng);
  return mesh;
}

Eigen::Vector3d Centroid(const TetMesh& mesh, int e) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
  return c;
}

GridActuationField Grid(const TetMesh& mesh, double spacing) {
  GridActuationFieldOptions options;
  options.node_spacing = spacing;
  return GridActuationField(mesh, options);
}

Eigen::MatrixXd RandomMatrix(int rows, int cols, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(*rng);
  return m;
}

TEST(GridActuationFieldTest, WeightsArePartitionOfUnityOverKeptNodes) {
  const TetMesh mesh = JitteredBar();
  const GridActuationField field = Grid(mesh, 0.7);
  EXPECT_EQ(field.num_elements(), mesh.num_tets());
  EXPECT_FALSE(field.per_element());
  const GridFieldDescription& grid = field.description();
  EXPECT_EQ(grid.spacing, 0.7);
  EXPECT_LE(field.num_nodes(), grid.grid_dims.prod());
  std::set<int> used;
  for (int e = 0; e < field.num_elements(); ++e) {
    EXPECT_NEAR(field.element_weights().col(e).sum(), 1.0, 1e-14);
    for (int c = 0; c < 8; ++c) {
      const int node = field.element_nodes()(c, e);
      ASSERT_GE(node, 0);
      ASSERT_LT(node, field.num_nodes());
      EXPECT_GE(field.element_weights()(c, e), 0.0);
      if (field.element_weights()(c, e) > 0.0) used.insert(node);
    }
  }
  EXPECT_EQ(static_cast<int>(used.size()), field.num_nodes()) << "every kept node is used";
  // Nodes are numbered in increasing grid index, and the grid covers the mesh.
  for (int n = 1; n < field.num_nodes(); ++n) {
    const Eigen::Vector3i a = grid.nodes.col(n - 1), b = grid.nodes.col(n);
    const long long ia = a[0] + grid.grid_dims[0] * (a[1] + 1LL * grid.grid_dims[1] * a[2]);
    const long long ib = b[0] + grid.grid_dims[0] * (b[1] + 1LL * grid.grid_dims[1] * b[2]);
    EXPECT_LT(ia, ib);
  }
  const Eigen::Vector3d grid_end =
      grid.origin + grid.spacing * (grid.grid_dims.cast<double>() - Eigen::Vector3d::Ones());
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(grid.origin[a], mesh.vertices.row(a).minCoeff());
    EXPECT_GE(grid_end[a], mesh.vertices.row(a).maxCoeff());
    // Centred: equal overhang on both sides.
    EXPECT_NEAR(mesh.vertices.row(a).minCoeff() - grid.origin[a],
                grid_end[a] - mesh.vertices.row(a).maxCoeff(), 1e-12);
  }
}

TEST(GridActuationFieldTest, ReproducesALinearFieldExactly) {
  const TetMesh mesh = JitteredBar();
  const GridActuationField field = Grid(mesh, 0.7);
  std::mt19937 rng(22);
  const Eigen::Matrix<double, 6, 3> slope = RandomMatrix(6, 3, &rng);
  const Vector6d offset = RandomMatrix(6, 1, &rng);
  NodeValueMatrix node_values(6, field.num_nodes());
  for (int n = 0; n < field.num_nodes(); ++n) {
    node_values.col(n) = slope * field.NodePosition(n) + offset;
  }
  ActuationMatrix a;
  field.Apply(node_values, &a);
  ASSERT_EQ(a.cols(), mesh.num_tets());
  ActuationMatrix expected(6, mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    expected.col(e) = IdentityActuation() + slope * Centroid(mesh, e) + offset;
  }
  EXPECT_LT(testing::RelativeError(a, expected), 1e-13);
}

TEST(GridActuationFieldTest, TransposeIsTheAdjointOfInterpolate) {
  for (bool per_element : {false, true}) {
    SCOPED_TRACE(per_element ? "per element" : "grid");
    const TetMesh mesh = JitteredBar();
    GridActuationFieldOptions options;
    options.node_spacing = 0.45;
    options.per_element = per_element;
    const GridActuationField field(mesh, options);
    std::mt19937 rng(23);
    const NodeValueMatrix x = RandomMatrix(6, field.num_nodes(), &rng);
    const ActuationMatrix y = RandomMatrix(6, field.num_elements(), &rng);
    ActuationMatrix ax;
    field.Interpolate(x, &ax);
    NodeValueMatrix aty;
    field.ApplyTranspose(y, &aty);
    ASSERT_EQ(aty.cols(), field.num_nodes());
    const double lhs = (ax.array() * y.array()).sum();
    const double rhs = (x.array() * aty.array()).sum();
    EXPECT_NEAR(lhs, rhs, 1e-12 * std::abs(lhs));
    EXPECT_GT(std::abs(lhs), 1.0);
    // Apply is I + Interpolate.
    ActuationMatrix applied;
    field.Apply(x, &applied);
    EXPECT_LT(testing::RelativeError(applied - IdentityActuations(field.num_elements()), ax),
              1e-15);
  }
}

// A spacing that gives fewer than 1e6 cells per axis but more grid nodes than a model
// file may hold (kMaxGridNodes) is refused when planned, naming the option: before, such
// a model was trained and saved, and then refused to load.
TEST(GridActuationFieldTest, PlanRefusesGridsTheModelReaderWouldRefuse) {
  const TetMesh mesh = testing::BarMesh(1, 1, 1, 1.0);
  GridActuationFieldOptions options;
  options.node_spacing = 3e-6;  // 333,334 cells per axis: 3.7e16 nodes
  double nodes = 0.0;
  std::string error;
  EXPECT_FALSE(PlanGridActuationField(mesh, options, &nodes, &error));
  EXPECT_NE(error.find("node_spacing"), std::string::npos) << error;
  EXPECT_NE(error.find("grid nodes"), std::string::npos) << error;
  options.node_spacing = 1e-4;  // 1e12 nodes: planned (bounded by 8 per element)
  EXPECT_TRUE(PlanGridActuationField(mesh, options, &nodes, &error)) << error;
  EXPECT_LE(nodes, 8.0 * mesh.num_tets());
}

TEST(GridActuationFieldTest, PerElementIsTheIdentityMap) {
  const TetMesh mesh = JitteredBar();
  GridActuationFieldOptions options;
  options.per_element = true;
  const GridActuationField field(mesh, options);
  EXPECT_TRUE(field.per_element());
  EXPECT_EQ(field.num_nodes(), mesh.num_tets());
  EXPECT_EQ(field.element_nodes().cols(), 0) << "no tables for the identity";
  std::mt19937 rng(24);
  const NodeValueMatrix v = RandomMatrix(6, field.num_nodes(), &rng);
  ActuationMatrix a;
  field.Apply(v, &a);
  EXPECT_EQ(a, v + IdentityActuations(mesh.num_tets()));
  NodeValueMatrix back;
  field.ApplyTranspose(v, &back);
  EXPECT_EQ(back, v);
}

TEST(GridActuationFieldTest, DefaultSpacingIsFourMeanEdgeLengths) {
  const TetMesh bar = testing::BarMesh(6, 5, 4, 0.5);
  // Kuhn tetrahedra have three cube edges, two face diagonals and one body diagonal.
  const double mean_edge = 0.5 * (3.0 + 2.0 * std::sqrt(2.0) + std::sqrt(3.0)) / 6.0;
  EXPECT_NEAR(MeanEdgeLength(bar), mean_edge, 1e-12);
  const GridActuationField field(bar, GridActuationFieldOptions());
  EXPECT_NEAR(field.description().spacing, 4.0 * mean_edge, 1e-12);
  // Extents 3, 2.5, 2 over a spacing of 2.53: 2 x 1 x 1 cells.
  EXPECT_EQ(field.description().grid_dims, Eigen::Vector3i(3, 2, 2));
  EXPECT_EQ(field.num_nodes(), 12);
  // A spacing larger than the mesh: one cell, eight nodes.
  EXPECT_EQ(Grid(bar, 10.0).num_nodes(), 8);
}

TEST(GridActuationFieldTest, KeepsOnlyNodesThatInfluenceSomeElement) {
  // An L-shaped body: the grid's empty corner has no kept nodes.
  TetMesh bar = testing::BarMesh(8, 1, 1, 1.0);
  TetMesh post = testing::BarMesh(1, 8, 1, 1.0);
  TetMesh mesh;
  mesh.vertices.resize(3, bar.num_vertices() + post.num_vertices());
  mesh.vertices << bar.vertices, post.vertices;
  mesh.tets.resize(4, bar.num_tets() + post.num_tets());
  mesh.tets << bar.tets, (post.tets.array() + bar.num_vertices()).matrix();
  const GridActuationField field = Grid(mesh, 1.0);
  EXPECT_EQ(field.description().grid_dims, Eigen::Vector3i(9, 9, 2));
  // Centroids lie strictly inside the unit cubes, so the kept nodes are the corners of
  // the 15 distinct cubes: per z layer 9 x 2 + 2 x 9 - 2 x 2 = 32, so 64 of the 162.
  EXPECT_EQ(field.num_nodes(), 64);
}

TEST(GridActuationFieldTest, FromDescriptionRebuildsTheSameFieldOrFailsOnAnotherMesh) {
  const TetMesh mesh = JitteredBar();
  const GridActuationField field = Grid(mesh, 0.7);
  GridActuationField rebuilt;
  std::string error;
  ASSERT_TRUE(GridActuationField::FromDescription(mesh, field.description(), "decoder.txt",
                                                  &rebuilt, &error))
      << error;
  EXPECT_EQ(rebuilt.element_nodes(), field.element_nodes());
  EXPECT_EQ(rebuilt.element_weights(), field.element_weights());
  EXPECT_EQ(rebuilt.num_nodes(), field.num_nodes());

  // Another element count.
  const TetMesh smaller = testing::BarMesh(3, 3, 2, 0.5);
  EXPECT_FALSE(GridActuationField::FromDescription(smaller, field.description(), "decoder.txt",
                                                   &rebuilt, &error));
  EXPECT_NE(error.find("decoder.txt"), std::string::npos) << error;
  EXPECT_NE(error.find("elements"), std::string::npos) << error;
  // Same count, but the body lies elsewhere.
  TetMesh moved = mesh;
  moved.vertices.row(0).array() += 5.0;
  EXPECT_FALSE(GridActuationField::FromDescription(moved, field.description(), "decoder.txt",
                                                   &rebuilt, &error));
  EXPECT_NE(error.find("outside"), std::string::npos) << error;
  // Same count and box, but a node the description does not keep.
  GridFieldDescription missing = field.description();
  missing.nodes = missing.nodes.rightCols(missing.nodes.cols() - 1).eval();
  EXPECT_FALSE(
      GridActuationField::FromDescription(mesh, missing, "decoder.txt", &rebuilt, &error));
  EXPECT_NE(error.find("does not keep"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
