#include "mesh/tet_faces.h"

#include <glog/logging.h>

#include <algorithm>
#include <utility>

namespace aqs {
namespace mesh_internal {

const int kOutwardFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

TetFaceTable BuildTetFaceTable(const TetMesh& mesh) {
  const int num_vertices = mesh.num_vertices();
  const int num_tets = mesh.num_tets();
  TetFaceTable table;
  table.offsets.assign(num_vertices + 1, 0);
  auto sorted_face = [&mesh](int t, int f, int* a, int* b, int* c) {
    int v[3] = {mesh.tets(kOutwardFace[f][0], t), mesh.tets(kOutwardFace[f][1], t),
                mesh.tets(kOutwardFace[f][2], t)};
    if (v[0] > v[1]) std::swap(v[0], v[1]);
    if (v[1] > v[2]) std::swap(v[1], v[2]);
    if (v[0] > v[1]) std::swap(v[0], v[1]);
    *a = v[0];
    *b = v[1];
    *c = v[2];
  };
  // Counting sort by the smallest vertex.
  for (int t = 0; t < num_tets; ++t) {
    for (int i = 0; i < 4; ++i) {
      const int v = mesh.tets(i, t);
      CHECK(v >= 0 && v < num_vertices) << "element " << t << " has vertex index " << v
                                        << " out of range; validate the mesh first";
    }
    for (int f = 0; f < 4; ++f) {
      int a, b, c;
      sorted_face(t, f, &a, &b, &c);
      ++table.offsets[a + 1];
    }
  }
  for (int v = 0; v < num_vertices; ++v) table.offsets[v + 1] += table.offsets[v];
  table.faces.resize(static_cast<size_t>(num_tets) * 4);
  std::vector<int> cursor(table.offsets.begin(), table.offsets.end() - 1);
  for (int t = 0; t < num_tets; ++t) {
    for (int f = 0; f < 4; ++f) {
      int a, b, c;
      sorted_face(t, f, &a, &b, &c);
      table.faces[cursor[a]++] = TetFace{b, c, t, f};
    }
  }
  for (int v = 0; v < num_vertices; ++v) {
    std::sort(table.faces.begin() + table.offsets[v], table.faces.begin() + table.offsets[v + 1],
              [](const TetFace& x, const TetFace& y) {
                if (x.b != y.b) return x.b < y.b;
                if (x.c != y.c) return x.c < y.c;
                return x.tet < y.tet;
              });
  }
  return table;
}

}  // namespace mesh_internal
}  // namespace aqs
