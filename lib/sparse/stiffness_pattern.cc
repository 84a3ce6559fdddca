#include "sparse/stiffness_pattern.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

namespace aqs {

StiffnessPattern::StiffnessPattern(const Eigen::Matrix4Xi& tets, const std::vector<bool>& fixed,
                                   const std::vector<std::vector<int>>& couplings)
    : vertex_to_free_(fixed.size(), -1), tets_(tets) {
  const int num_vertices = static_cast<int>(fixed.size());
  for (int v = 0; v < num_vertices; ++v) {
    if (!fixed[v]) {
      vertex_to_free_[v] = static_cast<int>(free_to_vertex_.size());
      free_to_vertex_.push_back(v);
    }
  }
  const int num_free = num_free_vertices();
  const int num_elements = static_cast<int>(tets.cols());

  // Lower neighbours (free index < own) of each free vertex, as a CSR adjacency.
  std::vector<std::vector<int>> lower(num_free);
  for (int e = 0; e < num_elements; ++e) {
    for (int k = 0; k < 4; ++k) {
      const int fu = vertex_to_free_[tets(k, e)];
      if (fu < 0) continue;
      for (int l = 0; l < 4; ++l) {
        const int fv = vertex_to_free_[tets(l, e)];
        if (fv > fu) lower[fv].push_back(fu);
      }
    }
  }
  for (const std::vector<int>& set : couplings) {
    for (int u : set) {
      CHECK(u >= 0 && u < num_vertices) << "coupled vertex " << u;
      const int fu = vertex_to_free_[u];
      if (fu < 0) continue;
      for (int v : set) {
        const int fv = vertex_to_free_[v];
        if (fv > fu) lower[fv].push_back(fu);
      }
    }
  }
  for (auto& list : lower) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }

  column_starts_.assign(3 * static_cast<size_t>(num_free) + 1, 0);
  int64_t nnz = 0;
  for (int fv = 0; fv < num_free; ++fv) {
    for (int d = 0; d < 3; ++d) {
      column_starts_[3 * fv + d] = nnz;
      nnz += 3 * static_cast<int64_t>(lower[fv].size()) + d + 1;
    }
  }
  column_starts_[3 * num_free] = nnz;
  row_indices_.resize(nnz);
  for (int fv = 0; fv < num_free; ++fv) {
    for (int d = 0; d < 3; ++d) {
      int64_t pos = column_starts_[3 * fv + d];
      for (int fu : lower[fv]) {
        for (int c = 0; c < 3; ++c) row_indices_[pos++] = 3 * static_cast<int64_t>(fu) + c;
      }
      for (int c = 0; c <= d; ++c) row_indices_[pos++] = 3 * static_cast<int64_t>(fv) + c;
    }
  }

  pair_slot_.assign(16 * static_cast<size_t>(num_elements), -1);
  for (int e = 0; e < num_elements; ++e) {
    for (int k = 0; k < 4; ++k) {
      const int fu = vertex_to_free_[tets(k, e)];
      if (fu < 0) continue;
      for (int l = 0; l < 4; ++l) {
        const int fv = vertex_to_free_[tets(l, e)];
        if (fv < 0 || fu > fv) continue;
        const std::vector<int>& list = lower[fv];
        const int slot =
            fu == fv ? static_cast<int>(list.size())
                     : static_cast<int>(std::lower_bound(list.begin(), list.end(), fu) -
                                        list.begin());
        pair_slot_[16 * static_cast<size_t>(e) + 4 * k + l] = slot;
      }
    }
  }
}

int64_t StiffnessPattern::BlockOffset(int e, int k, int l, int d) const {
  const int32_t slot = pair_slot_[16 * static_cast<size_t>(e) + 4 * k + l];
  if (slot < 0) return -1;
  const int fv = vertex_to_free_[tets_(l, e)];
  return column_starts_[3 * static_cast<int64_t>(fv) + d] + 3 * static_cast<int64_t>(slot);
}

int64_t StiffnessPattern::VertexBlockOffset(int u, int v, int d) const {
  const int fu = vertex_to_free_[u], fv = vertex_to_free_[v];
  if (fu < 0 || fv < 0 || fu > fv) return -1;
  const int64_t start = column_starts_[3 * static_cast<int64_t>(fv) + d];
  // The column holds 3 rows per lower neighbour, then the diagonal block's d + 1 rows.
  const int64_t diagonal = column_starts_[3 * static_cast<int64_t>(fv) + d + 1] - (d + 1);
  if (fu == fv) return diagonal;
  const int64_t row = 3 * static_cast<int64_t>(fu);
  const auto begin = row_indices_.begin() + start, end = row_indices_.begin() + diagonal;
  const auto it = std::lower_bound(begin, end, row);
  if (it == end || *it != row) return -1;
  return it - row_indices_.begin();
}

void AddVertexHessian(const std::vector<int>& vertices, const Eigen::MatrixXd& hessian,
                      const StiffnessPattern& pattern, std::vector<double>* values) {
  const int n = static_cast<int>(vertices.size());
  CHECK_EQ(hessian.rows(), 3 * n);
  CHECK_EQ(hessian.cols(), 3 * n);
  for (int i = 0; i < n; ++i) {
    const int fi = pattern.free_index(vertices[i]);
    if (fi < 0) continue;
    for (int j = 0; j < n; ++j) {
      const int fj = pattern.free_index(vertices[j]);
      if (fj < 0 || fi > fj) continue;
      for (int d = 0; d < 3; ++d) {
        const int64_t offset = pattern.VertexBlockOffset(vertices[i], vertices[j], d);
        CHECK_GE(offset, 0) << "vertices " << vertices[i] << " and " << vertices[j]
                            << " are not coupled in the stiffness pattern";
        const int rows = i == j ? d + 1 : 3;
        for (int c = 0; c < rows; ++c) (*values)[offset + c] += hessian(3 * i + c, 3 * j + d);
      }
    }
  }
}

double MaxFreeVertexNorm(const StiffnessPattern& pattern, const Eigen::Matrix3Xd& per_vertex) {
  double largest = 0.0;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    const double norm = per_vertex.col(pattern.vertex_of_free(f)).norm();
    if (std::isnan(norm) || norm > largest) largest = norm;  // a NaN column: NaN, kept
  }
  return largest;
}

}  // namespace aqs
