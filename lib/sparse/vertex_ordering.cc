#include "sparse/vertex_ordering.h"

#include <algorithm>
#include <cstdint>

#include <glog/logging.h>

#include "sparse/sparse_cholesky.h"

namespace aqs {

std::vector<int> FillReducingVertexOrder(const Eigen::Matrix4Xi& tets,
                                         const std::vector<bool>& fixed) {
  const int num_vertices = static_cast<int>(fixed.size());
  std::vector<int> free_index(num_vertices, -1), free_vertices;
  for (int v = 0; v < num_vertices; ++v) {
    if (!fixed[v]) {
      free_index[v] = static_cast<int>(free_vertices.size());
      free_vertices.push_back(v);
    }
  }
  const int n = static_cast<int>(free_vertices.size());
  if (n == 0) return {};
  // Upper-triangular CSC pattern of the vertex graph (with diagonal).
  std::vector<std::vector<int>> lower(n);
  for (int e = 0; e < tets.cols(); ++e) {
    for (int k = 0; k < 4; ++k) {
      const int fu = free_index[tets(k, e)];
      if (fu < 0) continue;
      for (int l = 0; l < 4; ++l) {
        const int fv = free_index[tets(l, e)];
        if (fv > fu) lower[fv].push_back(fu);
      }
    }
  }
  std::vector<int64_t> column_starts(n + 1, 0), row_indices;
  for (int v = 0; v < n; ++v) {
    std::vector<int>& list = lower[v];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    column_starts[v] = static_cast<int64_t>(row_indices.size());
    row_indices.insert(row_indices.end(), list.begin(), list.end());
    row_indices.push_back(v);
    std::vector<int>().swap(list);
  }
  column_starts[n] = static_cast<int64_t>(row_indices.size());
  SparseCholesky analysis(n, &column_starts, &row_indices);
  std::string error;
  if (!analysis.Analyze(&error)) {
    // The vertices' own order is as valid, only slower to factorize; the factorizations
    // that follow would meet the same shortage and report it.
    LOG(WARNING) << "no fill-reducing vertex order: " << error;
    return free_vertices;
  }
  const std::vector<int64_t> perm = analysis.Permutation();
  std::vector<int> order(n);
  for (int k = 0; k < n; ++k) order[k] = free_vertices[perm[k]];
  return order;
}

}  // namespace aqs
