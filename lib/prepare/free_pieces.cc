#include "prepare/free_pieces.h"

#include <string>
#include <utility>
#include <vector>

#include <glog/logging.h>

#include "mesh/element_subset.h"
#include "mesh/tet_components.h"

namespace aqs {
namespace {

// The entries of `vertices` that survive (new_index >= 0), renumbered.
std::vector<int> Renumbered(const std::vector<int>& vertices, const std::vector<int>& new_index) {
  std::vector<int> kept;
  kept.reserve(vertices.size());
  for (int v : vertices) {
    if (new_index[v] >= 0) kept.push_back(new_index[v]);
  }
  return kept;
}

}  // namespace

bool RemoveFreePieces(ActiveModel* model, FreePieceRemoval* removal, std::string* error) {
  CHECK(removal != nullptr);
  *removal = FreePieceRemoval();
  const TetMesh& mesh = model->mesh;
  CHECK_EQ(model->mu.size(), mesh.num_tets());
  std::vector<bool> held(mesh.num_vertices(), false);
  for (int v : model->static_vertices) held[v] = true;
  for (const Bone& bone : model->bones) {
    for (int v : bone.vertices) held[v] = true;
  }
  std::vector<int> piece;
  const std::vector<MeshPiece> pieces = DescribeMeshPieces(mesh, held, &piece);
  std::vector<int> embedded(pieces.size(), 0);
  for (int e : model->embedding.element) ++embedded[piece[e]];
  std::vector<bool> remove(pieces.size(), false);
  for (size_t p = 0; p < pieces.size(); ++p) {
    if (pieces[p].held) continue;
    if (embedded[p] > 0) {
      *error = UnheldPieceText(pieces[p], static_cast<int>(pieces.size())) + ", and " +
               std::to_string(embedded[p]) + " surface vertices are embedded in it (fix at " +
               "least 3 of its vertices not on one line with the boundary rules, or leave it " +
               "out of the mesh)";
      return false;
    }
    remove[p] = true;
    ++removal->pieces;
    removal->elements += pieces[p].elements;
    if (removal->first_element < 0) removal->first_element = pieces[p].first_element;
  }
  if (removal->pieces == 0) return true;

  std::vector<int> kept_elements, new_element(mesh.num_tets(), -1);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    if (remove[piece[e]]) continue;
    new_element[e] = static_cast<int>(kept_elements.size());
    kept_elements.push_back(e);
  }
  std::vector<int> kept_vertices;
  TetMesh kept = ElementSubset(mesh, kept_elements, &kept_vertices);
  std::vector<int> new_vertex(mesh.num_vertices(), -1);
  for (size_t v = 0; v < kept_vertices.size(); ++v) {
    new_vertex[kept_vertices[v]] = static_cast<int>(v);
  }
  removal->vertices = mesh.num_vertices() - kept.num_vertices();

  Eigen::VectorXd mu(kept.num_tets());
  for (int e = 0; e < kept.num_tets(); ++e) mu[e] = model->mu[kept_elements[e]];
  for (int& e : model->embedding.element) {
    CHECK_GE(new_element[e], 0) << "an embedded element in a removed piece";
    e = new_element[e];
  }
  model->static_vertices = Renumbered(model->static_vertices, new_vertex);
  for (Bone& bone : model->bones) bone.vertices = Renumbered(bone.vertices, new_vertex);
  model->mu = std::move(mu);
  model->mesh = std::move(kept);
  return true;
}

}  // namespace aqs
