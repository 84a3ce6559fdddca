#include "mesh/tet_components.h"

#include <algorithm>
#include <numeric>

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "mesh/tet_faces.h"

namespace aqs {

int TetMeshPieces(const TetMesh& mesh, std::vector<int>* piece_of_element) {
  const int nt = mesh.num_tets();
  std::vector<int> parent(nt);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&parent](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  const mesh_internal::TetFaceTable table = mesh_internal::BuildTetFaceTable(mesh);
  for (int a = 0; a + 1 < static_cast<int>(table.offsets.size()); ++a) {
    for (int i = table.offsets[a]; i + 1 < table.offsets[a + 1]; ++i) {
      const mesh_internal::TetFace& f = table.faces[i];
      const mesh_internal::TetFace& g = table.faces[i + 1];
      if (f.b != g.b || f.c != g.c) continue;
      const int x = find(f.tet), y = find(g.tet);
      if (x != y) parent[std::max(x, y)] = std::min(x, y);
    }
  }
  piece_of_element->assign(nt, -1);
  std::vector<int> number(nt, -1);
  int pieces = 0;
  for (int t = 0; t < nt; ++t) {
    const int root = find(t);
    if (number[root] < 0) number[root] = pieces++;
    (*piece_of_element)[t] = number[root];
  }
  return pieces;
}

bool EveryPieceIsHeld(const TetMesh& mesh, const std::vector<bool>& fixed, std::string* error) {
  CHECK_EQ(static_cast<int>(fixed.size()), mesh.num_vertices());
  std::vector<int> piece;
  const int pieces = TetMeshPieces(mesh, &piece);
  // Per piece: its size, first element, and fixed vertices a, b (apart) and whether one
  // more lies off the line through them. (A vertex shared by two pieces, at an edge or a
  // point, holds both.)
  std::vector<int> size(pieces, 0), first(pieces, -1), a(pieces, -1), b(pieces, -1);
  std::vector<char> plane(pieces, 0);
  for (int t = 0; t < mesh.num_tets(); ++t) {
    const int p = piece[t];
    ++size[p];
    if (first[p] < 0) first[p] = t;
    for (int k = 0; k < 4 && !plane[p]; ++k) {
      const int v = mesh.tets(k, t);
      if (!fixed[v]) continue;
      const Eigen::Vector3d x = mesh.vertices.col(v);
      if (a[p] < 0) {
        a[p] = v;
        continue;
      }
      const Eigen::Vector3d from_a = x - mesh.vertices.col(a[p]);
      if (b[p] < 0) {
        if (from_a.squaredNorm() > 0) b[p] = v;
        continue;
      }
      const Eigen::Vector3d axis = mesh.vertices.col(b[p]) - mesh.vertices.col(a[p]);
      // Off the line: the sine of the angle at a above 1e-6.
      plane[p] = from_a.cross(axis).norm() > 1e-6 * from_a.norm() * axis.norm();
    }
  }
  for (int p = 0; p < pieces; ++p) {
    if (plane[p]) continue;
    *error = "the simulation mesh has " + std::to_string(pieces) + " piece" +
             (pieces == 1 ? "" : "s") + " (elements joined by shared triangles), and the " +
             "piece of element " + std::to_string(first[p]) + " (0-based; " +
             std::to_string(size[p]) + " elements) has " +
             (a[p] < 0 ? "no fixed vertex" : "fewer than 3 fixed vertices off one line") +
             ": it could move rigidly, and its equilibrium is not unique (fix at least 3 of "
             "its vertices not on one line, or leave it out of the mesh)";
    return false;
  }
  return true;
}

}  // namespace aqs
