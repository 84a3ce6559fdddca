#ifndef AQS_FIT_FIT_COST_H_
#define AQS_FIT_FIT_COST_H_

// Internal to lib/fit: included by the LatentFitter's own .cc files only.

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <Eigen/Core>
#include <glog/logging.h>

#include "fit/fit_equilibrium.h"
#include "fit/latent_fit.h"
#include "fit/point_cloud_matching.h"
#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"

namespace aqs {

// Residuals sqrt(w_k / sum w) (p_k(x*) - y_k) (3 K) over the blocks z and, if fitted,
// one 6-number block per bone, at the equilibrium FitEquilibrium prepares (shared, or
// owned when there is no evaluation callback).
class LatentFitter::FitCost final : public ceres::CostFunction {
  struct Stencil;  // below

 public:
  // A point cloud without correspondence: one residual per scan point, its robust
  // distance to the simulated surface, re-matched (closest points) at every evaluation:
  //   r_i = sqrt(1/M) R(d_i),  R(d) = d / sqrt(1 + (d/s)^2)  (s = robust_scale; R(d) = d
  // for s <= 0), d_i the distance signed by the side of the matched triangle, clamped
  // to +-max_distance (beyond it the residual is constant). The derivative of a
  // closest-point distance is u^T dp (u the unit direction from the scan point to its
  // closest point, signed likewise; the closest point's sliding is second order), so
  // dr_i = sqrt(1/M) R'(d_i) u_i^T dp_i, exact wherever the matching is unique.
  FitCost(LatentFitter* fitter, FitEquilibrium* equilibrium, const Eigen::Matrix3Xd& cloud,
          const PointCloudFitOptions& options)
      : fitter_(fitter), equilibrium_(equilibrium), target_(&own_target_), cloud_(&cloud),
        cloud_options_(options) {
    CHECK_GT(cloud.cols(), 0);
    set_num_residuals(static_cast<int>(cloud.cols()));
    *mutable_parameter_block_sizes() = equilibrium->block_sizes();
  }

  FitCost(LatentFitter* fitter, FitEquilibrium* equilibrium, const FitTarget& target)
      : fitter_(fitter), equilibrium_(equilibrium), target_(&target) {
    const ActiveModel& model = fitter->model_;
    const int k = target.num_points();
    set_num_residuals(3 * k);
    *mutable_parameter_block_sizes() = equilibrium->block_sizes();
    double total = 0.0;
    for (int i = 0; i < k; ++i) total += target.weights.size() > 0 ? target.weights[i] : 1.0;
    CHECK_GT(total, 0.0) << "fit targets need a positive total weight";
    // Each target point as a combination of 12 state vertices plus a constant offset.
    stencils_.resize(k);
    for (int i = 0; i < k; ++i) {
      Stencil& s = stencils_[i];
      const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
      s.scale = std::sqrt(w / total);
      s.projector = s.scale * Eigen::Matrix3d::Identity();
      if (target.normals.cols() == k) {
        const Eigen::Vector3d n = target.normals.col(i);
        const Eigen::Matrix3d nn = n * n.transpose();
        s.projector =
            s.scale * (nn + target.tangential_weight * (Eigen::Matrix3d::Identity() - nn));
      }
      for (int c = 0; c < 3; ++c) {
        const int v = target.vertices(c, i);
        CHECK(v >= 0 && v < model.num_surface_vertices()) << "target vertex " << v;
      }
      SetSurfaceStencil(model, target.vertices.col(i), target.barycentric.col(i), &s);
    }
  }

  // A cost with its own FitEquilibrium (no evaluation callback: NewCostFunction).
  void Own(std::unique_ptr<FitEquilibrium> equilibrium) {
    own_equilibrium_ = std::move(equilibrium);
  }

  // Cloud mode: matches the scan to the surface of state x; sets the stencils of the
  // matched points, the residuals and the gradient rows (R'(d) u / sqrt(M), 3 x M).
  void MatchCloud(const Eigen::Matrix3Xd& x, double* residuals, std::vector<Stencil>* stencils,
                  Eigen::Matrix3Xd* cloud_rows) const {
    const ActiveModel& model = fitter_->model_;
    const Eigen::Matrix3Xd surface = EmbeddedPositions(model.embedding, model.mesh.tets, x);
    const Eigen::Matrix3Xi& triangles = model.neutral.triangles;
    const TriangleBvh bvh(surface, triangles);
    const std::vector<ClosestPointResult> closest =
        bvh.ClosestPoints(*cloud_, fitter_->options_.num_threads);
    const Eigen::Index m = cloud_->cols();
    const double scale = 1.0 / std::sqrt(static_cast<double>(m));
    const double s = cloud_options_.robust_scale;
    const double cap = cloud_options_.max_distance;
    stencils->resize(m);
    cloud_rows->resize(3, m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const ClosestPointResult& c = closest[i];
      Stencil& st = (*stencils)[i];
      const Eigen::Vector3i t = triangles.col(c.triangle);
      SetSurfaceStencil(model, t, c.barycentric, &st);
      // Signed by the side of the triangle: sigma = sign(v . n) |v|, v = p - y, whose
      // gradient sign(v . n) v / |v| is n itself for a closest point inside a triangle,
      // so the residual is smooth where the surface passes through a scan point.
      Eigen::Vector3d n =
          (surface.col(t[1]) - surface.col(t[0])).cross(surface.col(t[2]) - surface.col(t[0]));
      const double length = n.norm();
      n = length > 0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d v = c.point - cloud_->col(i);
      double d = c.distance;
      Eigen::Vector3d u = d > 1e-12 ? Eigen::Vector3d(v / d) : n;
      if (u.dot(n) < 0) {
        u = -u;
        d = -d;
      }
      bool clamped = false;
      if (cap > 0 && std::abs(d) > cap) {
        d = d > 0 ? cap : -cap;
        clamped = true;
      }
      double slope = 1.0;
      residuals[i] = scale * RobustDistance(d, s, &slope);
      cloud_rows->col(i) = clamped ? Eigen::Vector3d::Zero() : Eigen::Vector3d(scale * slope * u);
    }
  }

  // Of this cost's residuals at a point (`residuals`, num_residuals() of them), those
  // the fit uses: their count, and (1/2) sum r^2 into *cost. Cloud mode leaves out the
  // points beyond max_distance (their residual is the clamp's constant, their Jacobian
  // row zero); targets leave out points of weight 0 (a matching round's unmatched).
  int UsedResiduals(const double* residuals, double* cost) const {
    *cost = 0.0;
    int used = 0;
    auto use = [&](double r) {
      *cost += 0.5 * r * r;
      ++used;
    };
    if (cloud_ != nullptr) {
      const double cap = cloud_options_.max_distance;
      // The clamped residual, computed as MatchCloud computes it (bit for bit).
      const double scale = 1.0 / std::sqrt(static_cast<double>(cloud_->cols()));
      double slope = 0.0;
      const double clamp =
          cap > 0 && std::isfinite(cap)
              ? std::abs(scale * RobustDistance(cap, cloud_options_.robust_scale, &slope))
              : std::numeric_limits<double>::infinity();
      for (Eigen::Index i = 0; i < cloud_->cols(); ++i) {
        if (std::abs(residuals[i]) < clamp) use(residuals[i]);
      }
      return used;
    }
    for (size_t i = 0; i < stencils_.size(); ++i) {
      if (stencils_[i].scale == 0.0) continue;
      for (int c = 0; c < 3; ++c) use(residuals[3 * i + c]);
    }
    return used;
  }

  // A read of the point FitEquilibrium prepared (it prepares it here only when there is
  // no evaluation callback, see there).
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const bool want_z = jacobians != nullptr && jacobians[0] != nullptr;
    bool want_bones = false;
    for (size_t b = 1; jacobians != nullptr && b < parameter_block_sizes().size(); ++b) {
      want_bones |= jacobians[b] != nullptr;
    }
    const FitEquilibrium::Point* point = equilibrium_->Prepare(parameters, want_z || want_bones);
    if (point == nullptr) return false;  // Ceres treats the step as unsuccessful
    const Eigen::Matrix3Xd& x = point->state;
    const std::vector<Stencil>* stencils = &stencils_;
    std::vector<Stencil> matched;
    Eigen::Matrix3Xd cloud_rows;
    if (cloud_ != nullptr) {
      MatchCloud(x, residuals, &matched, &cloud_rows);
      stencils = &matched;
    } else {
      const int k = target_->num_points();
      for (int i = 0; i < k; ++i) {
        const Stencil& s = stencils_[i];
        Eigen::Vector3d p = s.offset;
        for (int j = 0; j < 12; ++j) p += s.weight[j] * x.col(s.vertex[j]);
        Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) =
            s.projector * (p - target_->positions.col(i));
      }
    }
    if (!want_z && !want_bones) return true;
    if (want_z) FillJacobian(equilibrium_->LatentProduct(), *stencils, cloud_rows, jacobians[0]);
    for (size_t b = 0; b + 1 < parameter_block_sizes().size(); ++b) {
      if (jacobians[1 + b] == nullptr) continue;
      FillJacobian(equilibrium_->BoneProduct(b), *stencils, cloud_rows, jacobians[1 + b]);
    }
    return true;
  }

 private:
  struct Stencil {
    int vertex[12];
    double weight[12];
    Eigen::Vector3d offset;
    double scale;
    Eigen::Matrix3d projector;  // scale * P_k (identity scaled for point-to-point)
  };

  // The vertex, weight and offset entries of *s for the surface point sum_c
  // barycentric(c) * (embedded surface vertex vertices(c)): the three embedding
  // stencils, scaled (entries 4 c .. 4 c + 3 for corner c).
  static void SetSurfaceStencil(const ActiveModel& model, const Eigen::Vector3i& vertices,
                                const Eigen::Vector3d& barycentric, Stencil* s) {
    s->offset.setZero();
    for (int c = 0; c < 3; ++c) {
      const PointStencil point = EmbeddingStencil(model.embedding, model.mesh.tets, vertices[c]);
      s->offset += barycentric[c] * point.offset;
      for (int j = 0; j < 4; ++j) {
        s->vertex[4 * c + j] = point.vertex[j];
        s->weight[4 * c + j] = barycentric[c] * point.weight[j];
      }
    }
  }

  // Row-major (3K x columns; cloud mode M x columns) Jacobian of the residuals from dx
  // (3 num_vertices x columns), through the points' stencils (and cloud mode's rows).
  void FillJacobian(const Eigen::MatrixXd& dx, const std::vector<Stencil>& stencils,
                    const Eigen::Matrix3Xd& cloud_rows, double* out) const {
    const Eigen::Index columns = dx.cols();
    if (cloud_ != nullptr) {  // one row per scan point: g_i^T dp_i
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
          out, cloud_->cols(), columns);
      for (Eigen::Index i = 0; i < cloud_->cols(); ++i) {
        const Stencil& s = stencils[i];
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(columns);
        if (cloud_rows.col(i).squaredNorm() > 0) {
          for (int j = 0; j < 12; ++j) {
            if (s.weight[j] != 0.0) {
              row += s.weight[j] * (cloud_rows.col(i).transpose() *
                                    dx.middleRows(3 * static_cast<Eigen::Index>(s.vertex[j]), 3));
            }
          }
        }
        jac.row(i) = row;
      }
      return;
    }
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
        out, 3 * target_->num_points(), columns);
    for (int i = 0; i < target_->num_points(); ++i) {
      const Stencil& s = stencils[i];
      Eigen::MatrixXd dp = Eigen::MatrixXd::Zero(3, columns);
      for (int j = 0; j < 12; ++j) {
        if (s.weight[j] != 0.0) {
          dp += s.weight[j] * dx.middleRows(3 * static_cast<Eigen::Index>(s.vertex[j]), 3);
        }
      }
      jac.middleRows(3 * i, 3) = s.projector * dp;
    }
  }

  LatentFitter* fitter_;
  FitEquilibrium* equilibrium_;
  std::unique_ptr<FitEquilibrium> own_equilibrium_;
  FitTarget own_target_;  // empty: cloud mode
  const FitTarget* target_;
  const Eigen::Matrix3Xd* cloud_ = nullptr;
  PointCloudFitOptions cloud_options_;
  // Per target point (fixed targets; cloud mode matches at every evaluation).
  std::vector<Stencil> stencils_;
};

}  // namespace aqs

#endif  // AQS_FIT_FIT_COST_H_
