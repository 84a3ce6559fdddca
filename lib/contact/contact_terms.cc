#include "contact/contact_terms.h"

#include <algorithm>
#include <cmath>

#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <glog/logging.h>

namespace aqs {

bool PlaneDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   const Eigen::Vector3d& c, double* s, Eigen::Matrix<double, 3, 4>* gradient,
                   Eigen::Vector3d* barycentric) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  if (!(length > 1e-300)) return false;
  const Eigen::Vector3d n = cross / length;
  const Eigen::Vector3d v = p - a;
  *s = n.dot(v);
  if (gradient != nullptr) {
    // s = v . n(cr): ds = n . dv + u . dcr with u = (I - n n^T) v / |cr|.
    const Eigen::Vector3d u = (v - n * n.dot(v)) / length;
    const Eigen::Vector3d ds_db = e2.cross(u);
    const Eigen::Vector3d ds_dc = u.cross(e1);
    gradient->col(0) = n;
    gradient->col(1) = -n - ds_db - ds_dc;
    gradient->col(2) = ds_db;
    gradient->col(3) = ds_dc;
  }
  if (barycentric != nullptr) {
    const Eigen::Vector3d w = v - *s * n;
    Eigen::Matrix2d gram;
    gram << e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2);
    const Eigen::Vector2d beta = gram.inverse() * Eigen::Vector2d(e1.dot(w), e2.dot(w));
    *barycentric = Eigen::Vector3d(1.0 - beta[0] - beta[1], beta[0], beta[1]);
  }
  return true;
}

bool EdgeDistance(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
                  const Eigen::Vector3d& qb, double min_sine, double* s,
                  Eigen::Matrix<double, 3, 4>* gradient, double* u, double* v) {
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  const double scale = e1.norm() * e2.norm();
  if (!(scale > 1e-300) || !(length > min_sine * scale)) return false;
  const Eigen::Vector3d n = cross / length;
  const Eigen::Vector3d d = pa - qa;
  *s = n.dot(d);
  if (gradient != nullptr) {
    // s = d . n(cr), cr = e1 x e2: ds = n . dd + w . dcr with w = (I - n n^T) d / |cr|,
    // and w . (de1 x e2 + e1 x de2) = de1 . (e2 x w) + de2 . (w x e1).
    const Eigen::Vector3d w = (d - n * *s) / length;
    const Eigen::Vector3d ds_de1 = e2.cross(w);
    const Eigen::Vector3d ds_de2 = w.cross(e1);
    gradient->col(0) = n - ds_de1;
    gradient->col(1) = ds_de1;
    gradient->col(2) = -n - ds_de2;
    gradient->col(3) = ds_de2;
  }
  // Closest points: minimize |d + u e1 - v e2|^2 (the normal equations' determinant is
  // -|e1 x e2|^2).
  const double aa = e1.dot(e1), ab = e1.dot(e2), bb = e2.dot(e2);
  const double ad = e1.dot(d), bd = e2.dot(d);
  const double det = length * length;
  if (u != nullptr) *u = (ab * bd - bb * ad) / det;
  if (v != nullptr) *v = (aa * bd - ab * ad) / det;
  return true;
}

bool EdgeSine(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
              const Eigen::Vector3d& qb, double* sine, Eigen::Matrix<double, 3, 4>* gradient) {
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const double a = e1.norm(), b = e2.norm();
  if (!(a > 1e-300) || !(b > 1e-300)) return false;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  *sine = length / (a * b);
  if (gradient != nullptr) {
    // sine = |e1 x e2| / (|e1| |e2|): d|c| = de1 . (e2 x c) / |c| + de2 . (c x e1) / |c|.
    Eigen::Vector3d d_e1 = -*sine * e1 / (a * a), d_e2 = -*sine * e2 / (b * b);
    if (length > 1e-300) {
      d_e1 += e2.cross(cross) / (length * a * b);
      d_e2 += cross.cross(e1) / (length * a * b);
    }
    gradient->col(0) = -d_e1;
    gradient->col(1) = d_e1;
    gradient->col(2) = -d_e2;
    gradient->col(3) = d_e2;
  }
  return true;
}

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

// ---- Obstacles ----

namespace {

class ObstacleCost final : public ceres::CostFunction {
 public:
  ObstacleCost(const ObstacleContactTerm& term, const PointStencil& point, double stiffness,
               double thickness)
      : term_(term), point_(point), scale_(std::sqrt(stiffness)), thickness_(thickness) {
    set_num_residuals(1);
    for (int j = 0; j < 4; ++j) mutable_parameter_block_sizes()->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Vector3d p = point_.offset;
    for (int j = 0; j < 4; ++j) p += point_.weight[j] * Eigen::Map<const Eigen::Vector3d>(parameters[j]);
    Eigen::Vector3d g;
    const double d = term_.Distance(p, &g);
    const bool active = d < thickness_;
    residuals[0] = active ? scale_ * (thickness_ - d) : 0.0;
    if (jacobians == nullptr) return true;
    for (int j = 0; j < 4; ++j) {
      if (jacobians[j] == nullptr) continue;
      Eigen::Map<Eigen::RowVector3d> jac(jacobians[j]);
      if (active) {
        jac = -scale_ * point_.weight[j] * g.transpose();
      } else {
        jac.setZero();
      }
    }
    return true;
  }

 private:
  const ObstacleContactTerm& term_;
  PointStencil point_;
  double scale_;
  double thickness_;
};

}  // namespace

ObstacleContactTerm::ObstacleContactTerm(const std::vector<PointStencil>& points,
                                         const Eigen::VectorXd& stiffness, double thickness,
                                         const std::vector<const Obstacle*>& obstacles)
    : points_(points), stiffness_(stiffness), thickness_(thickness), obstacles_(obstacles) {
  CHECK_EQ(stiffness.size(), static_cast<Eigen::Index>(points.size()));
  CHECK_GT(thickness, 0.0);
}

double ObstacleContactTerm::Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  double best = std::numeric_limits<double>::infinity();
  gradient->setZero();
  for (const Obstacle* obstacle : obstacles_) {
    Eigen::Vector3d g;
    // Beyond a few thicknesses the exact distance does not matter.
    const double d = obstacle->SignedDistance(p, &g, std::max(10.0 * thickness_, std::min(best, 1e300)));
    if (d < best) {
      best = d;
      *gradient = g;
    }
  }
  return best;
}

double ObstacleContactTerm::AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                                 Eigen::Matrix3Xd* gradient) const {
  double energy = 0.0;
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    const double d = Distance(s.Position(x), &g);
    if (!(d < thickness_)) continue;
    const double gap = thickness_ - d;
    energy += 0.5 * stiffness_[i] * gap * gap;
    for (int j = 0; j < 4; ++j) gradient->col(s.vertex[j]) -= stiffness_[i] * gap * s.weight[j] * g;
  }
  return energy;
}

void ObstacleContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>&,
                                       const StiffnessPattern&, std::vector<double>*) const {
  LOG(FATAL) << "ObstacleContactTerm has no stiffness (Levenberg-Marquardt only)";
}

ceres::CostFunction* ObstacleContactTerm::NewCostFunction(int i) const {
  return new ObstacleCost(*this, points_[i], stiffness_[i], thickness_);
}

void ObstacleContactTerm::AddResidualBlocks(ceres::Problem* problem,
                                            const std::vector<double*>& vertex_blocks) const {
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    problem->AddResidualBlock(NewCostFunction(static_cast<int>(i)), nullptr,
                              vertex_blocks[s.vertex[0]], vertex_blocks[s.vertex[1]],
                              vertex_blocks[s.vertex[2]], vertex_blocks[s.vertex[3]]);
  }
}

// ---- Self contact ----

namespace {

// The pair's simulation vertices without repeats, and for each of its 16 stencil slots
// (point 0..3, corner c's 4 + 4 c ..) the index of its block.
struct PairBlocks {
  std::vector<int> vertices;
  int slot[16];
};

PairBlocks BlocksOf(const SelfContactPair& pair) {
  PairBlocks blocks;
  const PointStencil* stencils[4] = {&pair.point, &pair.corner[0], &pair.corner[1], &pair.corner[2]};
  for (int m = 0; m < 4; ++m) {
    for (int j = 0; j < 4; ++j) {
      const int v = stencils[m]->vertex[j];
      auto it = std::find(blocks.vertices.begin(), blocks.vertices.end(), v);
      if (it == blocks.vertices.end()) {
        blocks.slot[4 * m + j] = static_cast<int>(blocks.vertices.size());
        blocks.vertices.push_back(v);
      } else {
        blocks.slot[4 * m + j] = static_cast<int>(it - blocks.vertices.begin());
      }
    }
  }
  return blocks;
}

// The pair's residual sqrt(k) (thickness + offset - s) (0 if inactive) at the four
// points, and its gradient with respect to them (3 x 4: point, corners).
double PairResidual(const SelfContactPair& pair, const Eigen::Vector3d points[4], double thickness,
                    double max_depth, double margin, Eigen::Matrix<double, 3, 4>* gradient) {
  thickness += pair.offset;
  double s = 0, outside = 0;
  Eigen::Matrix<double, 3, 4> ds;
  gradient->setZero();
  if (!SelfContactDistance(pair, points, &s, &ds, &outside)) return 0.0;
  if (!(s < thickness) || !(s > -max_depth) || outside > margin) return 0.0;
  const double scale = std::sqrt(pair.stiffness);
  if (pair.kind == SelfContactPair::Kind::kPointTriangle) {
    *gradient = -scale * ds;
    return scale * (thickness - s);
  }
  // Edge-edge: weight w = sqrt(smoothstep(x)) = x sqrt(3 - 2 x) of the sine's position x
  // in the fade band (dw/dx = 0 at x = 1; w^2 is C1 at x = 0).
  double sine = 0;
  Eigen::Matrix<double, 3, 4> dsine;
  if (!EdgeSine(points[0], points[1], points[2], points[3], &sine, &dsine)) return 0.0;
  const double x = (sine - kEdgeFadeSine) / (kFullEdgeSine - kEdgeFadeSine);
  if (!(x > 0.0)) return 0.0;
  double w = 1.0, dw_dx = 0.0;
  if (x < 1.0) {
    const double root = std::sqrt(3.0 - 2.0 * x);
    w = x * root;
    dw_dx = root - x / root;
  }
  const double r = scale * (thickness - s);
  *gradient = -scale * w * ds + r * dw_dx / (kFullEdgeSine - kEdgeFadeSine) * dsine;
  return w * r;
}

class SelfContactCost final : public ceres::CostFunction {
 public:
  SelfContactCost(const SelfContactPair& pair, double thickness, double max_depth, double margin)
      : pair_(pair), blocks_(BlocksOf(pair)), thickness_(thickness), max_depth_(max_depth),
        margin_(margin) {
    set_num_residuals(1);
    for (size_t b = 0; b < blocks_.vertices.size(); ++b) mutable_parameter_block_sizes()->push_back(3);
  }

  const std::vector<int>& block_vertices() const { return blocks_.vertices; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const PointStencil* stencils[4] = {&pair_.point, &pair_.corner[0], &pair_.corner[1],
                                       &pair_.corner[2]};
    Eigen::Vector3d points[4];
    for (int m = 0; m < 4; ++m) {
      points[m] = stencils[m]->offset;
      for (int j = 0; j < 4; ++j) {
        points[m] += stencils[m]->weight[j] *
                     Eigen::Map<const Eigen::Vector3d>(parameters[blocks_.slot[4 * m + j]]);
      }
    }
    Eigen::Matrix<double, 3, 4> gradient;
    residuals[0] = PairResidual(pair_, points, thickness_, max_depth_, margin_, &gradient);
    if (jacobians == nullptr) return true;
    for (size_t b = 0; b < blocks_.vertices.size(); ++b) {
      if (jacobians[b] != nullptr) Eigen::Map<Eigen::RowVector3d>(jacobians[b]).setZero();
    }
    for (int m = 0; m < 4; ++m) {
      for (int j = 0; j < 4; ++j) {
        double* jac = jacobians[blocks_.slot[4 * m + j]];
        if (jac == nullptr) continue;
        Eigen::Map<Eigen::RowVector3d>(jac) += stencils[m]->weight[j] * gradient.col(m).transpose();
      }
    }
    return true;
  }

 private:
  SelfContactPair pair_;
  PairBlocks blocks_;
  double thickness_, max_depth_, margin_;
};

}  // namespace

SelfContactTerm::SelfContactTerm(const std::vector<SelfContactPair>& pairs, double thickness,
                                 double max_depth, double margin)
    : pairs_(pairs), thickness_(thickness), max_depth_(max_depth), margin_(margin) {
  CHECK_GT(thickness, 0.0);
}

double SelfContactTerm::AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                             Eigen::Matrix3Xd* gradient) const {
  double energy = 0.0;
  for (const SelfContactPair& pair : pairs_) {
    const PointStencil* stencils[4] = {&pair.point, &pair.corner[0], &pair.corner[1], &pair.corner[2]};
    Eigen::Vector3d points[4];
    for (int m = 0; m < 4; ++m) points[m] = stencils[m]->Position(x);
    Eigen::Matrix<double, 3, 4> dr;
    const double r = PairResidual(pair, points, thickness_, max_depth_, margin_, &dr);
    if (r == 0.0) continue;
    energy += 0.5 * r * r;
    for (int m = 0; m < 4; ++m) {
      for (int j = 0; j < 4; ++j) gradient->col(stencils[m]->vertex[j]) += r * stencils[m]->weight[j] * dr.col(m);
    }
  }
  return energy;
}

void SelfContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>&,
                                   const StiffnessPattern&, std::vector<double>*) const {
  LOG(FATAL) << "SelfContactTerm has no stiffness (Levenberg-Marquardt only)";
}

ceres::CostFunction* SelfContactTerm::NewCostFunction(int i, std::vector<int>* block_vertices) const {
  auto* cost = new SelfContactCost(pairs_[i], thickness_, max_depth_, margin_);
  if (block_vertices != nullptr) *block_vertices = cost->block_vertices();
  return cost;
}

void SelfContactTerm::AddResidualBlocks(ceres::Problem* problem,
                                        const std::vector<double*>& vertex_blocks) const {
  for (int i = 0; i < num_pairs(); ++i) {
    std::vector<int> vertices;
    ceres::CostFunction* cost = NewCostFunction(i, &vertices);
    std::vector<double*> blocks;
    for (int v : vertices) blocks.push_back(vertex_blocks[v]);
    problem->AddResidualBlock(cost, nullptr, blocks);
  }
}

}  // namespace aqs
