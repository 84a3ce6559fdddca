#ifndef AQS_EVAL_SCAN_ERROR_SPLIT_H_
#define AQS_EVAL_SCAN_ERROR_SPLIT_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// What a scan fit's vertex error is made of, over the region the scan sees. A scan
// measures where the surface is, not where each of its points went: a fit can slide the
// surface along itself (a mouth corner moving sideways over a smooth cheek) at no cost
// to the scan. So the error of a fit against the true pose (with correspondence) splits
// into a part along the truth's normals, which the scan measures, and a tangential part,
// which it does not.

// The median, over the distinct positions of `cloud` (3 x M, M >= 2; copies of a point,
// as a triangle soup's vertices, count once), of the distance to the nearest other one:
// the scan's sampling spacing; 0 if all points coincide. Points are bucketed in a
// uniform grid of cell D / sqrt(M) (a surface sampled by M points is about that far
// apart), D the diagonal of the box between the 2% and 98% quantiles of each coordinate
// (the whole bounding box if that one is a point), so that a few stray points far from
// the scan do not make the cells large; each point counts the nearest within the 27
// cells around its own (its nearest neighbour if closer than a cell; the cell size if
// there is none). O(M log M) (the copies are found by sorting) for a scan of a surface,
// with or without stray points (before 2026-12-07 one stray point put the scan into a
// few cells: 80,000 points took 24.7 s instead of 0.12 s).
double MedianPointSpacing(const Eigen::Matrix3Xd& cloud);

// The entries v of `candidates` (column indices of `vertices`, 3 x n) with a point of
// `cloud` (3 x M) within `radius` (> 0) of vertices.col(v), in the order given.
std::vector<int> VerticesNearCloud(const Eigen::Matrix3Xd& vertices,
                                   const std::vector<int>& candidates,
                                   const Eigen::Matrix3Xd& cloud, double radius);

// A vertex is in the region a scan sees if a scan point lies within this many of the
// scan's sampling spacings (MedianPointSpacing) of it.
constexpr double kScannedSpacings = 2.0;

// The region a scan sees: the entries of `candidates` (columns of `vertices`, 3 x n, the
// true surface) within kScannedSpacings x MedianPointSpacing(cloud) of a point of
// `cloud` (3 x M), in the order given; empty if the cloud has fewer than 2 distinct
// points (copies of one point count once).
std::vector<int> ScannedVertices(const Eigen::Matrix3Xd& vertices,
                                 const std::vector<int>& candidates,
                                 const Eigen::Matrix3Xd& cloud);

// Mean error of a surface against the truth over some vertices, split along the truth's
// unit vertex normals n: normal = mean |(s - t) . n|, tangential = mean |(s - t) - ((s -
// t) . n) n|, total = mean |s - t|.
struct NormalTangentialError {
  double normal = 0.0;
  double tangential = 0.0;
  double total = 0.0;
};

// The split of surface (3 x n) against truth (3 x n) with the truth's unit vertex normals
// `normals` (3 x n) over `vertices` (indices into the columns; all zero if empty).
NormalTangentialError SplitError(const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& truth,
                                 const Eigen::Matrix3Xd& normals, const std::vector<int>& vertices);

}  // namespace aqs

#endif  // AQS_EVAL_SCAN_ERROR_SPLIT_H_
