#include "fit/fit_target.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <glog/logging.h>

#include "util/number_format.h"

namespace aqs {

bool ValidateFitTarget(const FitTarget& target, int num_surface_vertices, std::string* error) {
  const Eigen::Index k = target.positions.cols();
  const auto fail = [error](const std::string& message) {
    *error = "fit target: " + message;
    return false;
  };
  if (k == 0) return fail("it has no points");
  if (target.vertices.cols() != k || target.barycentric.cols() != k) {
    return fail("it has " + std::to_string(k) + " positions but " +
                std::to_string(target.vertices.cols()) + " vertex triples and " +
                std::to_string(target.barycentric.cols()) + " barycentric triples");
  }
  if (target.weights.size() != 0 && target.weights.size() != k) {
    return fail("it has " + std::to_string(k) + " points but " +
                std::to_string(target.weights.size()) + " weights");
  }
  if (target.normals.cols() != 0 && target.normals.cols() != k) {
    return fail("it has " + std::to_string(k) + " points but " +
                std::to_string(target.normals.cols()) + " normals");
  }
  if (!std::isfinite(target.tangential_weight) || target.tangential_weight < 0) {
    return fail("the tangential weight must be finite and >= 0");
  }
  double total = 0.0;
  for (Eigen::Index i = 0; i < k; ++i) {
    const std::string point = "point " + std::to_string(i);
    for (int c = 0; c < 3; ++c) {
      const int v = target.vertices(c, i);
      if (v < 0 || v >= num_surface_vertices) {
        return fail(point + " is on vertex " + std::to_string(v) + ", not a surface vertex of "
                    "the model (0 to " + std::to_string(num_surface_vertices - 1) + ")");
      }
    }
    if (!target.barycentric.col(i).allFinite()) {
      return fail(point + " has non-finite barycentric coordinates");
    }
    if (!target.positions.col(i).allFinite()) return fail(point + " has a non-finite position");
    if (target.normals.cols() == k && !target.normals.col(i).allFinite()) {
      return fail(point + " has a non-finite normal");
    }
    const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
    if (!std::isfinite(w) || w < 0) {
      return fail(point + " has the weight " + FormatDouble(w) + " (finite and >= 0)");
    }
    total += w;
  }
  if (!(total > 0)) return fail("its weights sum to 0");
  return true;
}

FitTarget VertexTarget(const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions) {
  CHECK_EQ(positions.cols(), static_cast<Eigen::Index>(vertices.size()));
  FitTarget target;
  const int k = static_cast<int>(vertices.size());
  target.vertices.resize(3, k);
  target.barycentric.setZero(3, k);
  for (int i = 0; i < k; ++i) {
    target.vertices.col(i).setConstant(vertices[i]);
    target.barycentric(0, i) = 1.0;
  }
  target.positions = positions;
  return target;
}

FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface) {
  std::vector<int> all(surface.cols());
  for (Eigen::Index i = 0; i < surface.cols(); ++i) all[i] = static_cast<int>(i);
  return VertexTarget(all, surface);
}

double TotalWeight(const FitTarget& target) {
  if (target.weights.size() == 0) return target.num_points();
  return target.weights.sum();
}

double PriorPoints(const FitTarget& target, double cap) {
  return PriorPoints(TotalWeight(target), cap);
}

double PriorPoints(double total_weight, double cap) {
  return cap > 0 ? std::min(total_weight, cap) : total_weight;
}

Eigen::Matrix3Xd TargetPointsOn(const FitTarget& target, const Eigen::Matrix3Xd& surface) {
  Eigen::Matrix3Xd p = Eigen::Matrix3Xd::Zero(3, target.num_points());
  for (int i = 0; i < target.num_points(); ++i) {
    for (int c = 0; c < 3; ++c) {
      p.col(i) += target.barycentric(c, i) * surface.col(target.vertices(c, i));
    }
  }
  return p;
}

double TargetDataTerm(const FitTarget& target, const Eigen::Matrix3Xd& surface) {
  const Eigen::Matrix3Xd p = TargetPointsOn(target, surface);
  double data = 0.0;
  for (int i = 0; i < target.num_points(); ++i) {
    const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
    Eigen::Vector3d d = p.col(i) - target.positions.col(i);
    if (target.normals.cols() == target.num_points()) {
      const Eigen::Vector3d n = target.normals.col(i);
      const Eigen::Vector3d normal_part = n.dot(d) * n;
      d = normal_part + target.tangential_weight * (d - normal_part);
    }
    data += w * d.squaredNorm();
  }
  return data / TotalWeight(target);
}

}  // namespace aqs
