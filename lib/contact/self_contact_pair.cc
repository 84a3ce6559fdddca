#include "contact/self_contact_pair.h"

#include <algorithm>

#include "geometry/distance/edge_distance.h"
#include "geometry/distance/edge_sine.h"
#include "geometry/distance/plane_distance.h"
#include "geometry/distance/triangle_quality.h"

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

bool PairableTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c) {
  double quality = 0;
  return TriangleQuality(a, b, c, &quality, nullptr) && quality >= kMinTriangleQuality;
}

SelfContactFadeBand FadeBandOf(const SelfContactPair& pair) {
  if (pair.kind == SelfContactPair::Kind::kPointTriangle) {
    return {kTriangleFadeQuality, kFullTriangleQuality};
  }
  return {kEdgeFadeSine, kFullEdgeSine};
}

bool SelfContactFadeVariable(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                             double* value, Eigen::Matrix<double, 3, 4>* gradient) {
  if (pair.kind == SelfContactPair::Kind::kEdgeEdge) {
    return EdgeSine(points[0], points[1], points[2], points[3], value, gradient);
  }
  Eigen::Matrix3d corners;
  if (!TriangleQuality(points[1], points[2], points[3], value,
                       gradient != nullptr ? &corners : nullptr)) {
    return false;
  }
  if (gradient != nullptr) {
    gradient->col(0).setZero();
    gradient->rightCols<3>() = corners;
  }
  return true;
}

bool SelfContactFadeVariableHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                    Eigen::Matrix<double, 12, 12>* hessian) {
  if (pair.kind == SelfContactPair::Kind::kEdgeEdge) {
    return EdgeSineHessian(points[0], points[1], points[2], points[3], hessian);
  }
  Eigen::Matrix<double, 9, 9> corners;
  if (!TriangleQualityHessian(points[1], points[2], points[3], &corners)) return false;
  hessian->setZero();
  hessian->bottomRightCorner<9, 9>() = corners;
  return true;
}

}  // namespace aqs
