#include "contact/self_contact_pair.h"

#include <algorithm>

#include "geometry/distance/edge_distance.h"
#include "geometry/distance/plane_distance.h"

namespace aqs {

bool SelfContactDistance(const SelfContactPair& pair, const Eigen::Vector3d points[4], double* s,
                         Eigen::Matrix<double, 3, 4>* gradient, double* outside) {
  if (pair.kind == SelfContactPair::Kind::kPointTriangle) {
    Eigen::Vector3d beta;
    if (!PlaneDistance(points[0], points[1], points[2], points[3], s, gradient, &beta)) return false;
    *outside = -beta.minCoeff();
    return true;
  }
  double u = 0, v = 0;
  if (!EdgeDistance(points[0], points[1], points[2], points[3], 0.0, s, gradient, &u, &v)) {
    return false;
  }
  *s *= pair.sign;
  if (gradient != nullptr) *gradient *= pair.sign;
  *outside = std::max({-u, u - 1.0, -v, v - 1.0});
  return true;
}

bool SelfContactDistanceHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                Eigen::Matrix<double, 12, 12>* hessian) {
  if (pair.kind == SelfContactPair::Kind::kPointTriangle) {
    return PlaneDistanceHessian(points[0], points[1], points[2], points[3], hessian);
  }
  if (!EdgeDistanceHessian(points[0], points[1], points[2], points[3], hessian)) return false;
  *hessian *= pair.sign;
  return true;
}

}  // namespace aqs
