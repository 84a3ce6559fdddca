#ifndef AQS_GEOMETRY_TRIANGLE_GRID_H_
#define AQS_GEOMETRY_TRIANGLE_GRID_H_

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// A uniform grid of cubic cells of edge at least `cell` (larger where the triangles'
// mean bounding-box side is, or where 2^20 cells would not span the vertices' extent)
// over the bounding boxes of triangles
// (columns of `triangles`, 3 x T, index columns of `vertices`, 3 x V), hashed by cell
// coordinates, for radius queries: every triangle is listed in each cell its bounding
// box overlaps. Degenerate triangles (a, b, b) serve as segments. The grid keeps no
// reference to its inputs.
class TriangleGrid {
 public:
  TriangleGrid(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles, double cell);

  // Into *out: the triangles whose bounding box overlaps one of the 27 cells at and
  // around the cell of p (so every triangle within `cell` of p, and more), each once, in
  // the order the cells list them. `marks` (one per triangle, per thread; resized to
  // the triangle count with -1, any initial values below 0) are set to `stamp` for the
  // triangles returned: stamps must differ between calls that share marks (e.g. the
  // query's index).
  void Near(const Eigen::Vector3d& p, int stamp, std::vector<int>* marks,
            std::vector<int>* out) const;

  // Into *out: the triangles listed in the cells that overlap the box [lo, hi] (so every
  // triangle whose bounding box meets the box, and more), each once, in the order the
  // cells list them; every triangle when the box spans more cells than the grid holds.
  // `marks` and `stamp` as in Near.
  void InBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int stamp,
             std::vector<int>* marks, std::vector<int>* out) const;

  // The cells' edge (>= the `cell` asked for).
  double cell() const { return cell_; }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const;
  // Appends the triangles of cell (i, j, k) not yet stamped to *out, stamping them.
  void CollectCell(int i, int j, int k, int stamp, std::vector<int>* marks,
                   std::vector<int>* out) const;
  static int64_t Key(int i, int j, int k);

  double cell_;
  int num_triangles_;
  Eigen::Vector3d lo_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

}  // namespace aqs

#endif  // AQS_GEOMETRY_TRIANGLE_GRID_H_
