#include "mesh/tet_components.h"

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "mesh/tet_faces.h"
#include "util/disjoint_sets.h"

namespace aqs {

int TetMeshPieces(const TetMesh& mesh, std::vector<int>* piece_of_element) {
  const int nt = mesh.num_tets();
  DisjointSets sets(nt);
  const mesh_internal::TetFaceTable table = mesh_internal::BuildTetFaceTable(mesh);
  for (int a = 0; a + 1 < static_cast<int>(table.offsets.size()); ++a) {
    for (int i = table.offsets[a]; i + 1 < table.offsets[a + 1]; ++i) {
      const mesh_internal::TetFace& f = table.faces[i];
      const mesh_internal::TetFace& g = table.faces[i + 1];
      if (f.b == g.b && f.c == g.c) sets.Union(f.tet, g.tet);
    }
  }
  piece_of_element->assign(nt, -1);
  std::vector<int> number(nt, -1);
  int pieces = 0;
  for (int t = 0; t < nt; ++t) {
    const int root = sets.Find(t);
    if (number[root] < 0) number[root] = pieces++;
    (*piece_of_element)[t] = number[root];
  }
  return pieces;
}

std::vector<MeshPiece> DescribeMeshPieces(const TetMesh& mesh, const std::vector<bool>& fixed,
                                          std::vector<int>* piece_of_element) {
  CHECK_EQ(static_cast<int>(fixed.size()), mesh.num_vertices());
  std::vector<int>& piece = *piece_of_element;
  const int pieces = TetMeshPieces(mesh, &piece);
  std::vector<MeshPiece> described(pieces);
  // Per piece: fixed vertices a, b (apart), and whether one more lies off their line.
  std::vector<int> a(pieces, -1), b(pieces, -1);
  for (int t = 0; t < mesh.num_tets(); ++t) {
    MeshPiece& d = described[piece[t]];
    const int p = piece[t];
    ++d.elements;
    if (d.first_element < 0) d.first_element = t;
    for (int k = 0; k < 4 && !d.held; ++k) {
      const int v = mesh.tets(k, t);
      if (!fixed[v]) continue;
      if (a[p] < 0) {
        a[p] = v;
        continue;
      }
      const Eigen::Vector3d from_a = mesh.vertices.col(v) - mesh.vertices.col(a[p]);
      if (b[p] < 0) {
        if (from_a.squaredNorm() > 0) b[p] = v;
        continue;
      }
      const Eigen::Vector3d axis = mesh.vertices.col(b[p]) - mesh.vertices.col(a[p]);
      // Off the line: the sine of the angle at a above 1e-6.
      d.held = from_a.cross(axis).norm() > 1e-6 * from_a.norm() * axis.norm();
    }
  }
  return described;
}

std::string UnheldPieceText(const MeshPiece& piece, int num_pieces) {
  return "the simulation mesh has " + std::to_string(num_pieces) + " piece" +
         (num_pieces == 1 ? "" : "s") + " (elements joined by shared triangles), and the " +
         "piece of element " + std::to_string(piece.first_element) + " (0-based; " +
         std::to_string(piece.elements) + " element" + (piece.elements == 1 ? "" : "s") +
         ") has fewer than 3 fixed vertices off one line: it could move rigidly, and its "
         "equilibrium is not unique";
}

bool EveryPieceIsHeld(const TetMesh& mesh, const std::vector<bool>& fixed, std::string* error) {
  std::vector<int> piece;
  const std::vector<MeshPiece> pieces = DescribeMeshPieces(mesh, fixed, &piece);
  for (const MeshPiece& p : pieces) {
    if (p.held) continue;
    *error = UnheldPieceText(p, static_cast<int>(pieces.size())) +
             " (fix at least 3 of its vertices not on one line, or leave it out of the mesh)";
    return false;
  }
  return true;
}

}  // namespace aqs
