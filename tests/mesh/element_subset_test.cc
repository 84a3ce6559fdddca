#include "mesh/element_subset.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "mesh/lattice.h"

namespace aqs {
namespace {

// A 2 x 2 x 2 BCC box with two elements appended: one on a face of the box's border,
// whose new vertex only it holds, and one on that element's outer face, whose new
// vertex again only it holds (removing it leaves the first one's vertex weak too).
TetMesh BoxWithHangingChain(int* first_hanging) {
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.type = LatticeType::kBcc;
  TetMesh box = MakeLatticeMesh(lattice);
  // A border face at x = 0: find an element with three vertices at x = 0.
  int face[3] = {-1, -1, -1};
  for (int e = 0; e < box.num_tets() && face[0] < 0; ++e) {
    int n = 0, on[4];
    for (int k = 0; k < 4; ++k) {
      if (box.vertices(0, box.tets(k, e)) == 0.0) on[n++] = box.tets(k, e);
    }
    if (n == 3) std::copy(on, on + 3, face);
  }
  EXPECT_GE(face[0], 0);
  const Eigen::Vector3d centre = (box.vertices.col(face[0]) + box.vertices.col(face[1]) +
                                  box.vertices.col(face[2])) / 3.0;
  TetMesh mesh;
  const int n = box.num_vertices();
  mesh.vertices.resize(3, n + 2);
  mesh.vertices.leftCols(n) = box.vertices;
  mesh.vertices.col(n) = centre - Eigen::Vector3d(0.5, 0, 0);
  mesh.vertices.col(n + 1) = centre - Eigen::Vector3d(1.0, 0, 0) + Eigen::Vector3d(0, 0.1, 0.1);
  mesh.tets.resize(4, box.num_tets() + 2);
  mesh.tets.leftCols(box.num_tets()) = box.tets;
  mesh.tets.col(box.num_tets()) << face[0], face[1], face[2], n;
  mesh.tets.col(box.num_tets() + 1) << face[0], face[1], n, n + 1;
  *first_hanging = box.num_tets();
  return mesh;
}

TEST(ElementSubsetTest, KeepsTheListedElementsAndRenumbersTheirVertices) {
  TetMesh mesh;
  mesh.vertices.resize(3, 6);
  for (int v = 0; v < 6; ++v) mesh.vertices.col(v) = Eigen::Vector3d(v, v * v, 1.0 - v);
  mesh.tets.resize(4, 2);
  mesh.tets.col(0) << 0, 1, 2, 3;
  mesh.tets.col(1) << 5, 4, 3, 2;
  const TetMesh subset = ElementSubset(mesh, {1});
  ASSERT_EQ(subset.num_tets(), 1);
  ASSERT_EQ(subset.num_vertices(), 4);
  // Vertices 2, 3, 4, 5 become 0, 1, 2, 3, in order of their old index.
  EXPECT_EQ(subset.tets.col(0), Eigen::Vector4i(3, 2, 1, 0));
  for (int v = 0; v < 4; ++v) EXPECT_EQ(subset.vertices.col(v), mesh.vertices.col(v + 2));
  EXPECT_EQ(ElementSubset(mesh, {}).num_vertices(), 0);
  const std::vector<int> count = VertexElementCounts(mesh);
  EXPECT_EQ(count, std::vector<int>({1, 1, 2, 2, 1, 1}));
}

TEST(ElementSubsetTest, PruningRemovesHangingElementsOnly) {
  int first_hanging = 0;
  const TetMesh mesh = BoxWithHangingChain(&first_hanging);
  const std::vector<int> count = VertexElementCounts(mesh);
  int below = 0;
  for (int c : count) below += c < 2;
  EXPECT_EQ(below, 1);  // the chain's last vertex

  int removed = -1;
  // One element per vertex is enough: nothing changes.
  TetMesh pruned = PruneWeaklyHeldElements(mesh, 1, &removed);
  EXPECT_EQ(removed, 0);
  EXPECT_EQ(pruned.num_tets(), mesh.num_tets());
  // Two: the chain's last element goes, then its first one (whose outer vertex the
  // last one shared), and the box stays whole.
  pruned = PruneWeaklyHeldElements(mesh, 2, &removed);
  EXPECT_EQ(removed, 2);
  EXPECT_EQ(pruned.num_tets(), first_hanging);
  EXPECT_EQ(pruned.num_vertices(), mesh.num_vertices() - 2);
  EXPECT_EQ(pruned.tets, mesh.tets.leftCols(first_hanging));
  // Many: the whole box goes, one layer after another.
  pruned = PruneWeaklyHeldElements(mesh, 24, &removed);
  EXPECT_EQ(removed, mesh.num_tets());
  EXPECT_EQ(pruned.num_tets(), 0);
  EXPECT_EQ(pruned.num_vertices(), 0);
}

// The pruning's definition, pass by pass over every element (quadratic on thin meshes):
// the elements it keeps.
std::vector<int> KeptByPasses(const TetMesh& mesh, int min_elements_per_vertex) {
  std::vector<int> count = VertexElementCounts(mesh);
  std::vector<char> removed(mesh.num_tets(), 0);
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<int> now;
    for (int e = 0; e < mesh.num_tets(); ++e) {
      bool weak = false;
      for (int k = 0; k < 4; ++k) weak = weak || count[mesh.tets(k, e)] < min_elements_per_vertex;
      if (!removed[e] && weak) now.push_back(e);
    }
    for (int e : now) {
      removed[e] = 1;
      changed = true;
      for (int k = 0; k < 4; ++k) --count[mesh.tets(k, e)];
    }
  }
  std::vector<int> kept;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    if (!removed[e]) kept.push_back(e);
  }
  return kept;
}

// The pruning looks only at the elements of the vertices the last pass weakened: it
// keeps what passes over every element keep, on a lattice with a tenth of its elements
// taken out at random, at every threshold; and a chain of 200,000 elements goes whole
// (in linear time: passes over every element took minutes at that length).
TEST(ElementSubsetTest, PruningKeepsWhatPassesOverEveryElementKeep) {
  LatticeOptions options;
  options.nx = 6;
  options.ny = 5;
  options.nz = 4;
  const TetMesh lattice = MakeLatticeMesh(options);
  std::mt19937 rng(11);
  std::vector<int> some;
  for (int e = 0; e < lattice.num_tets(); ++e) {
    if (std::uniform_real_distribution<double>(0.0, 1.0)(rng) > 0.1) some.push_back(e);
  }
  const TetMesh holed = ElementSubset(lattice, some);
  for (int threshold = 1; threshold <= 12; ++threshold) {
    const std::vector<int> kept = KeptByPasses(holed, threshold);
    std::vector<int> vertices;
    int removed = -1;
    const TetMesh pruned = PruneWeaklyHeldElements(holed, threshold, &removed, &vertices);
    EXPECT_EQ(pruned.tets, ElementSubset(holed, kept).tets) << threshold;
    EXPECT_EQ(removed, holed.num_tets() - static_cast<int>(kept.size())) << threshold;
  }
  TetMesh chain;
  const int n = 200000;
  chain.vertices.resize(3, n + 3);
  for (int v = 0; v < n + 3; ++v) chain.vertices.col(v) << v, (v % 3 == 1), (v % 3 == 2);
  chain.tets.resize(4, n);
  for (int t = 0; t < n; ++t) chain.tets.col(t) << t, t + 1, t + 2, t + 3;
  int removed = -1;
  EXPECT_EQ(PruneWeaklyHeldElements(chain, 4, &removed).num_tets(), 0);
  EXPECT_EQ(removed, n);
}

}  // namespace
}  // namespace aqs
