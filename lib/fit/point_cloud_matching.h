#ifndef AQS_FIT_POINT_CLOUD_MATCHING_H_
#define AQS_FIT_POINT_CLOUD_MATCHING_H_

#include <cmath>

#include <Eigen/Core>

#include "fit/latent_fit.h"

namespace aqs {

// Each scan point (points: 3 x M) matched to the closest point of `surface` (3 x
// num_surface_vertices; `triangles` 3 x T, of the neutral), as a FitTarget of M points
// (vertices and barycentric coordinates of the matched triangle, the scan points as
// positions) with robust weights: 0 beyond options.max_distance, else the Cauchy weight
// 1 / (1 + (d / options.robust_scale)^2) (1 if robust_scale <= 0); with
// options.tangential_weight < 1 also the matched triangles' unit normals. *used: the
// points of non-zero weight; *mean_distance: their mean distance (0 if none). The target
// of one matching round, and what the start choice scores scans with.
FitTarget MatchPointCloud(const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& surface,
                          const Eigen::Matrix3Xi& triangles, const PointCloudFitOptions& options,
                          int num_threads, int* used, double* mean_distance);

// The robust distance of scan fits, R(d) = d / sqrt(1 + (d/s)^2) (R(d) = d for s <= 0),
// and in *slope (may be null) its derivative R'(d) = (1 + (d/s)^2)^(-3/2).
inline double RobustDistance(double d, double s, double* slope) {
  if (s <= 0) {
    if (slope != nullptr) *slope = 1.0;
    return d;
  }
  const double q = 1.0 + (d / s) * (d / s);
  if (slope != nullptr) *slope = 1.0 / (q * std::sqrt(q));
  return d / std::sqrt(q);
}

// The data term a scan fit with options.rematch_every_evaluation minimizes (FitCost's
// cloud mode), at `surface` (3 x num_surface_vertices; `triangles` 3 x T):
//   (1/M) sum_i R(min(d_i, max_distance))^2,  R(d) = d / sqrt(1 + (d/s)^2),
// d_i the distance of scan point i (points: 3 x M) to its closest point of the surface,
// s = options.robust_scale (R(d) = d for s <= 0; no cap for max_distance <= 0).
// *within (may be null): the points with d_i <= max_distance (all if no cap).
double CloudDataTerm(const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& surface,
                     const Eigen::Matrix3Xi& triangles, const PointCloudFitOptions& options,
                     int num_threads, int* within);

}  // namespace aqs

#endif  // AQS_FIT_POINT_CLOUD_MATCHING_H_
