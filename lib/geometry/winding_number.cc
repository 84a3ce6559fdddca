#include "geometry/winding_number.h"

#include <glog/logging.h>

#include <cmath>

#include "util/option_checks.h"
#include "util/parallel_for.h"

namespace aqs {
namespace {

constexpr double kFourPi = 4.0 * M_PI;

// Sum of the solid angles of triangles order[begin .. end) seen from p.
double SolidAngleSum(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                     const std::vector<int>& order, int begin, int end, const Eigen::Vector3d& p) {
  double sum = 0;
  for (int i = begin; i < end; ++i) {
    const int t = order[i];
    sum += TriangleSolidAngle(p, vertices.col(triangles(0, t)), vertices.col(triangles(1, t)),
                              vertices.col(triangles(2, t)));
  }
  return sum;
}

void CheckIndices(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  for (int t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      CHECK(triangles(k, t) >= 0 && triangles(k, t) < vertices.cols())
          << "triangle " << t << " has vertex index " << triangles(k, t) << " out of range [0, "
          << vertices.cols() << ")";
    }
  }
}

}  // namespace

double TriangleSolidAngle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d x = a - p;
  const Eigen::Vector3d y = b - p;
  const Eigen::Vector3d z = c - p;
  const double determinant = x.dot(y.cross(z));
  if (determinant == 0) return 0;  // p in the triangle's plane, or a degenerate triangle
  const double lx = x.norm(), ly = y.norm(), lz = z.norm();
  const double denominator = lx * ly * lz + x.dot(y) * lz + x.dot(z) * ly + y.dot(z) * lx;
  return 2.0 * std::atan2(determinant, denominator);
}

double ExactWindingNumber(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                          const Eigen::Vector3d& point) {
  CheckIndices(vertices, triangles);
  double sum = 0;
  for (int t = 0; t < triangles.cols(); ++t) {
    sum += TriangleSolidAngle(point, vertices.col(triangles(0, t)), vertices.col(triangles(1, t)),
                              vertices.col(triangles(2, t)));
  }
  return sum / kFourPi;
}

Eigen::VectorXd ExactWindingNumbers(const Eigen::Matrix3Xd& vertices,
                                    const Eigen::Matrix3Xi& triangles,
                                    const Eigen::Matrix3Xd& points, int num_threads) {
  CheckIndices(vertices, triangles);
  Eigen::VectorXd result(points.cols());
  ParallelFor(
      num_threads, 0, static_cast<int>(points.cols()),
      [&](int, int i) {
        double sum = 0;
        for (int t = 0; t < triangles.cols(); ++t) {
          sum += TriangleSolidAngle(points.col(i), vertices.col(triangles(0, t)),
                                    vertices.col(triangles(1, t)), vertices.col(triangles(2, t)));
        }
        result(i) = sum / kFourPi;
      },
      16);
  return result;
}

bool FastWindingNumberOptions::Validate(std::string* error) const {
  return OptionChecks()
      .Positive("beta", beta)
      .IntInRange("expansion_order", expansion_order, 0, 2)
      .IntAtLeast("leaf_size", leaf_size, 1)
      .Done(error);
}

FastWindingNumber::FastWindingNumber(const Eigen::Matrix3Xd& vertices,
                                     const Eigen::Matrix3Xi& triangles,
                                     const FastWindingNumberOptions& options)
    : options_(options), vertices_(vertices), triangles_(triangles) {
  std::string invalid;
  CHECK(options.Validate(&invalid)) << invalid;
  tree_ = geometry_internal::BuildTriangleTree(vertices, triangles, options.leaf_size);

  // Per-triangle area-weighted normals (A n = cross / 2) and centroids.
  const int num_triangles = static_cast<int>(triangles.cols());
  Eigen::Matrix3Xd area_normals(3, num_triangles);
  Eigen::Matrix3Xd centroids(3, num_triangles);
  Eigen::VectorXd areas(num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    const Eigen::Vector3d a = vertices.col(triangles(0, t));
    const Eigen::Vector3d b = vertices.col(triangles(1, t));
    const Eigen::Vector3d c = vertices.col(triangles(2, t));
    area_normals.col(t) = 0.5 * (b - a).cross(c - a);
    areas(t) = area_normals.col(t).norm();
    centroids.col(t) = (a + b + c) / 3.0;
  }

  // Every node from its own triangles: O(M log M) in total.
  expansions_.resize(tree_.nodes.size());
  for (size_t n = 0; n < tree_.nodes.size(); ++n) {
    const geometry_internal::TriangleTreeNode& node = tree_.nodes[n];
    Expansion& e = expansions_[n];
    double total_area = 0;
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
    for (int i = node.begin; i < node.end; ++i) {
      const int t = tree_.order[i];
      total_area += areas(t);
      weighted += areas(t) * centroids.col(t);
    }
    e.centre = total_area > 0 ? Eigen::Vector3d(weighted / total_area) : node.box.center();
    e.radius = 0;
    e.n.setZero();
    e.m.setZero();
    for (auto& tk : e.t) tk.setZero();
    for (int i = node.begin; i < node.end; ++i) {
      const int t = tree_.order[i];
      const Eigen::Vector3d an = area_normals.col(t);
      Eigen::Vector3d d[3];
      for (int k = 0; k < 3; ++k) {
        d[k] = vertices.col(triangles(k, t)) - e.centre;
        e.radius = std::max(e.radius, d[k].norm());
      }
      e.n += an;
      e.m += an * (centroids.col(t) - e.centre).transpose();
      // integral_t (x - p~)(x - p~)^T dA = A / 12 (sum_k d_k d_k^T + s s^T), s = sum_k d_k.
      const Eigen::Vector3d s = d[0] + d[1] + d[2];
      const Eigen::Matrix3d second = (d[0] * d[0].transpose() + d[1] * d[1].transpose() +
                                      d[2] * d[2].transpose() + s * s.transpose()) /
                                     12.0;
      // n_i * A * second / A: the area cancels against the unit normal.
      for (int k = 0; k < 3; ++k) e.t[k] += an(k) * second;
    }
  }
}

double FastWindingNumber::FarField(const Expansion& e, const Eigen::Vector3d& point) const {
  // Dipole field F(x) = x / |x|^3 with x = p - q, expanded about p = p~ (the 1 / 4 pi
  // is applied by the caller).
  const Eigen::Vector3d x = e.centre - point;
  const double r2 = x.squaredNorm();
  const double r = std::sqrt(r2);
  const double inv_r3 = 1.0 / (r2 * r);
  double value = x.dot(e.n) * inv_r3;
  if (options_.expansion_order >= 1) {
    // dF_i/dx_j = delta_ij / r^3 - 3 x_i x_j / r^5.
    const double inv_r5 = inv_r3 / r2;
    value += e.m.trace() * inv_r3 - 3.0 * x.dot(e.m * x) * inv_r5;
    if (options_.expansion_order >= 2) {
      // d2F_i/dx_j dx_k = -3 (delta_ij x_k + delta_ik x_j + delta_jk x_i) / r^5
      //                   + 15 x_i x_j x_k / r^7, contracted with T_ijk / 2.
      const double inv_r7 = inv_r5 / r2;
      double diagonal_first = 0;  // sum_ik x_k T_iik (equal to sum_ij x_j T_iji)
      double trace_term = 0;      // sum_i x_i T_ijj
      double cubic = 0;           // sum_ijk x_i x_j x_k T_ijk
      for (int i = 0; i < 3; ++i) {
        diagonal_first += e.t[i].row(i).dot(x);
        trace_term += x(i) * e.t[i].trace();
        cubic += x(i) * x.dot(e.t[i] * x);
      }
      value += 0.5 * (-3.0 * (2.0 * diagonal_first + trace_term) * inv_r5 + 15.0 * cubic * inv_r7);
    }
  }
  return value;
}

double FastWindingNumber::WindingNumber(const Eigen::Vector3d& point) const {
  if (tree_.nodes.empty()) return 0;
  const double beta2 = options_.beta * options_.beta;
  double sum = 0;  // solid angles, / 4 pi at the end
  int stack[128];
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const int n = stack[--size];
    const Expansion& e = expansions_[n];
    const geometry_internal::TriangleTreeNode& node = tree_.nodes[n];
    if ((point - e.centre).squaredNorm() > beta2 * e.radius * e.radius) {
      sum += FarField(e, point);
    } else if (node.is_leaf()) {
      sum += SolidAngleSum(vertices_, triangles_, tree_.order, node.begin, node.end, point);
    } else {
      CHECK_LE(size + 2, 128) << "tree too deep";
      stack[size++] = node.right;
      stack[size++] = node.left;
    }
  }
  return sum / kFourPi;
}

Eigen::VectorXd FastWindingNumber::WindingNumbers(const Eigen::Matrix3Xd& points,
                                                  int num_threads) const {
  Eigen::VectorXd result(points.cols());
  ParallelFor(
      num_threads, 0, static_cast<int>(points.cols()),
      [&](int, int i) { result(i) = WindingNumber(points.col(i)); }, 64);
  return result;
}

}  // namespace aqs
