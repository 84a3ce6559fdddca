#include "mesh/element_subset.h"

#include <vector>

#include <glog/logging.h>

namespace aqs {

TetMesh ElementSubset(const TetMesh& mesh, const std::vector<int>& elements,
                      std::vector<int>* kept_vertices) {
  std::vector<int> new_index(mesh.num_vertices(), -1);
  for (int e : elements) {
    CHECK(e >= 0 && e < mesh.num_tets()) << "element " << e << " of " << mesh.num_tets();
    for (int k = 0; k < 4; ++k) new_index[mesh.tets(k, e)] = 0;
  }
  int num_vertices = 0;
  for (int& index : new_index) {
    if (index == 0) index = num_vertices++;
  }
  TetMesh subset;
  subset.vertices.resize(3, num_vertices);
  if (kept_vertices != nullptr) kept_vertices->assign(num_vertices, -1);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (new_index[v] < 0) continue;
    subset.vertices.col(new_index[v]) = mesh.vertices.col(v);
    if (kept_vertices != nullptr) (*kept_vertices)[new_index[v]] = v;
  }
  subset.tets.resize(4, static_cast<Eigen::Index>(elements.size()));
  for (size_t i = 0; i < elements.size(); ++i) {
    for (int k = 0; k < 4; ++k) subset.tets(k, i) = new_index[mesh.tets(k, elements[i])];
  }
  return subset;
}

std::vector<int> VertexElementCounts(const TetMesh& mesh) {
  std::vector<int> count(mesh.num_vertices(), 0);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) ++count[mesh.tets(k, e)];
  }
  return count;
}

TetMesh PruneWeaklyHeldElements(const TetMesh& mesh, int min_elements_per_vertex,
                                int* num_removed, std::vector<int>* kept_vertices) {
  std::vector<int> count = VertexElementCounts(mesh);
  std::vector<char> removed(mesh.num_tets(), 0);
  int total_removed = 0;
  // The elements at each vertex (CSR: vertex v's at element_of[first[v] .. first[v + 1])).
  std::vector<int> first(mesh.num_vertices() + 1, 0);
  for (int v = 0; v < mesh.num_vertices(); ++v) first[v + 1] = first[v] + count[v];
  std::vector<int> element_of(first.back());
  {
    std::vector<int> next(first.begin(), first.end() - 1);
    for (int e = 0; e < mesh.num_tets(); ++e) {
      for (int k = 0; k < 4; ++k) element_of[next[mesh.tets(k, e)]++] = e;
    }
  }
  // Each pass removes every element at a weak vertex; removals weaken their other
  // vertices, so passes repeat until one removes nothing. A pass looks only at the
  // elements of the vertices the last pass weakened (all elements in the first), so
  // that the whole costs O(elements) however many passes a thin mesh takes (scanning
  // every element in every pass was quadratic: a chain of 32,000 elements took 0.33 s).
  std::vector<int> candidates;
  if (min_elements_per_vertex > 1) {
    candidates.resize(mesh.num_tets());
    for (int e = 0; e < mesh.num_tets(); ++e) candidates[e] = e;
  }
  std::vector<int> seen(mesh.num_tets(), -1);  // the pass that last looked at an element
  std::vector<int> vertex_seen(mesh.num_vertices(), -1);  // ... that last weakened a vertex
  for (int pass = 0; !candidates.empty(); ++pass) {
    std::vector<int> weakened;
    for (int e : candidates) {
      if (removed[e] || seen[e] == pass) continue;
      seen[e] = pass;
      bool weak = false;
      for (int k = 0; k < 4 && !weak; ++k) weak = count[mesh.tets(k, e)] < min_elements_per_vertex;
      if (!weak) continue;
      removed[e] = 1;
      weakened.push_back(e);
      ++total_removed;
    }
    // Counts change after the pass, so that the pass's result does not depend on the
    // order of the elements.
    std::vector<int> weakened_vertices;
    for (int e : weakened) {
      for (int k = 0; k < 4; ++k) {
        const int v = mesh.tets(k, e);
        if (vertex_seen[v] != pass) weakened_vertices.push_back(v);
        vertex_seen[v] = pass;
        --count[v];
      }
    }
    candidates.clear();
    for (int v : weakened_vertices) {
      for (int i = first[v]; i < first[v + 1]; ++i) {
        if (!removed[element_of[i]]) candidates.push_back(element_of[i]);
      }
    }
  }
  std::vector<int> kept;
  kept.reserve(mesh.num_tets() - total_removed);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    if (!removed[e]) kept.push_back(e);
  }
  if (num_removed != nullptr) *num_removed = total_removed;
  return ElementSubset(mesh, kept, kept_vertices);
}

}  // namespace aqs
