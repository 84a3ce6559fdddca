#include "geometry/triangle_grid.h"

#include <algorithm>
#include <cmath>

namespace aqs {

TriangleGrid::TriangleGrid(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                           double cell)
    : cell_(cell), num_triangles_(static_cast<int>(triangles.cols())) {
  // Cells no smaller than the triangles' mean bounding-box side, nor than 2^-20 of the
  // vertices' extent: a cell far below the triangles' size lists each triangle in
  // (size / cell)^3 cells (a contact radius of 0.003 on the demo face took 2.8 GB), and
  // cell coordinates beyond int's range are undefined.
  double mean_side = 0.0;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    Eigen::Vector3d a = vertices.col(triangles(0, t)), b = a;
    for (int k = 1; k < 3; ++k) {
      a = a.cwiseMin(vertices.col(triangles(k, t)));
      b = b.cwiseMax(vertices.col(triangles(k, t)));
    }
    mean_side += (b - a).maxCoeff();
  }
  if (triangles.cols() > 0) mean_side /= static_cast<double>(triangles.cols());
  const double extent =
      vertices.cols() > 0
          ? (vertices.rowwise().maxCoeff() - vertices.rowwise().minCoeff()).maxCoeff()
          : 0.0;
  cell_ = std::max({cell, mean_side, std::ldexp(extent, -20)});
  lo_ = vertices.rowwise().minCoeff().array() - cell_;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    Eigen::Vector3d a = vertices.col(triangles(0, t)), b = a;
    for (int k = 1; k < 3; ++k) {
      a = a.cwiseMin(vertices.col(triangles(k, t)));
      b = b.cwiseMax(vertices.col(triangles(k, t)));
    }
    const Eigen::Vector3i ca = Cell(a), cb = Cell(b);
    for (int i = ca.x(); i <= cb.x(); ++i) {
      for (int j = ca.y(); j <= cb.y(); ++j) {
        for (int k = ca.z(); k <= cb.z(); ++k) cells_[Key(i, j, k)].push_back(static_cast<int>(t));
      }
    }
  }
}

void TriangleGrid::Near(const Eigen::Vector3d& p, int stamp, std::vector<int>* marks,
                        std::vector<int>* out) const {
  out->clear();
  marks->resize(num_triangles_, -1);
  const Eigen::Vector3i c = Cell(p);
  for (int i = c.x() - 1; i <= c.x() + 1; ++i) {
    for (int j = c.y() - 1; j <= c.y() + 1; ++j) {
      for (int k = c.z() - 1; k <= c.z() + 1; ++k) CollectCell(i, j, k, stamp, marks, out);
    }
  }
}

void TriangleGrid::InBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int stamp,
                         std::vector<int>* marks, std::vector<int>* out) const {
  out->clear();
  marks->resize(num_triangles_, -1);
  const Eigen::Vector3i ca = Cell(lo), cb = Cell(hi);
  const Eigen::Array3d span = (cb - ca).cast<double>().array() + 1.0;
  if ((span <= 0.0).any()) return;
  if (span.prod() > static_cast<double>(cells_.size())) {  // cheaper to list them all
    for (int t = 0; t < num_triangles_; ++t) {
      (*marks)[t] = stamp;
      out->push_back(t);
    }
    return;
  }
  for (int i = ca.x(); i <= cb.x(); ++i) {
    for (int j = ca.y(); j <= cb.y(); ++j) {
      for (int k = ca.z(); k <= cb.z(); ++k) CollectCell(i, j, k, stamp, marks, out);
    }
  }
}

void TriangleGrid::CollectCell(int i, int j, int k, int stamp, std::vector<int>* marks,
                               std::vector<int>* out) const {
  auto it = cells_.find(Key(i, j, k));
  if (it == cells_.end()) return;
  for (int t : it->second) {
    if ((*marks)[t] == stamp) continue;
    (*marks)[t] = stamp;
    out->push_back(t);
  }
}

Eigen::Vector3i TriangleGrid::Cell(const Eigen::Vector3d& p) const {
  // Clamped: a query far outside the grid stays in int's range (and finds nothing).
  return ((p - lo_) / cell_).array().floor().max(-1e9).min(1e9).cast<int>();
}

int64_t TriangleGrid::Key(int i, int j, int k) {
  return (static_cast<int64_t>(i) * 73856093) ^ (static_cast<int64_t>(j) * 19349663) ^
         (static_cast<int64_t>(k) * 83492791);
}

}  // namespace aqs
