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

namespace {

// [a]x: the cross-product matrix, [a]x b = a x b.
Eigen::Matrix3d Skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

// The Hessian of f = n . w, n = unit(u x v), with respect to (u, v, w) (9 x 9, blocks in
// that order). With m = u x v, N = |m|, P = I - n n^T, w_perp = P w and g = w_perp / N
// (= df/dm):
//   d2f/dm2 = -((n . w) P + w_perp n^T + n w_perp^T) / N^2,   d2f/dm dw = P / N,
// and m is bilinear in (u, v): dm/du = -[v]x, dm/dv = [u]x, d2(g . m)/du dv = -[g]x.
// Returns false if u x v vanishes.
bool UnitCrossDotHessian(const Eigen::Vector3d& u, const Eigen::Vector3d& v,
                         const Eigen::Vector3d& w, Eigen::Matrix<double, 9, 9>* hessian) {
  const Eigen::Vector3d m = u.cross(v);
  const double length = m.norm();
  if (!(length > 1e-300)) return false;
  const Eigen::Vector3d n = m / length;
  const double nw = n.dot(w);
  const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - n * n.transpose();
  const Eigen::Vector3d w_perp = w - nw * n;
  const Eigen::Vector3d g = w_perp / length;
  const Eigen::Matrix3d h_mm =
      -(nw * projector + w_perp * n.transpose() + n * w_perp.transpose()) / (length * length);
  const Eigen::Matrix3d h_mw = projector / length;
  const Eigen::Matrix3d dm_du = -Skew(v), dm_dv = Skew(u);
  hessian->setZero();
  hessian->block<3, 3>(0, 0) = dm_du.transpose() * h_mm * dm_du;
  hessian->block<3, 3>(3, 3) = dm_dv.transpose() * h_mm * dm_dv;
  hessian->block<3, 3>(0, 3) = dm_du.transpose() * h_mm * dm_dv - Skew(g);
  hessian->block<3, 3>(3, 0) = hessian->block<3, 3>(0, 3).transpose();
  hessian->block<3, 3>(0, 6) = dm_du.transpose() * h_mw;
  hessian->block<3, 3>(6, 0) = hessian->block<3, 3>(0, 6).transpose();
  hessian->block<3, 3>(3, 6) = dm_dv.transpose() * h_mw;
  hessian->block<3, 3>(6, 3) = hessian->block<3, 3>(3, 6).transpose();
  return true;
}

}  // namespace

namespace {

// Scatters a Hessian over differences (3 k x 3 k, difference a's DOFs at rows 3 a ..)
// to the four points: difference a = sum_j coefficients(a, j) points[j].
template <int kDifferences>
void ToPoints(const Eigen::Matrix<double, kDifferences, 4>& coefficients,
              const Eigen::Matrix<double, 3 * kDifferences, 3 * kDifferences>& h,
              Eigen::Matrix<double, 12, 12>* hessian) {
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
      for (int a = 0; a < kDifferences; ++a) {
        for (int b = 0; b < kDifferences; ++b) {
          const double c = coefficients(a, i) * coefficients(b, j);
          if (c != 0.0) block += c * h.template block<3, 3>(3 * a, 3 * b);
        }
      }
      hessian->block<3, 3>(3 * i, 3 * j) = block;
    }
  }
}

}  // namespace

bool EdgeSineHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                     const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                     Eigen::Matrix<double, 12, 12>* hessian) {
  // sine = exp(phi), phi = log |m| - log |e1| - log |e2|, m = e1 x e2:
  // Hess sine = sine (Hess phi + grad phi grad phi^T). With g = m / |m|^2,
  // d2 log|m| / dm2 = (I - 2 n n^T) / |m|^2, and m bilinear (dm/de1 = -[e2]x,
  // dm/de2 = [e1]x, d2(g . m)/de1 de2 = -[g]x); d2 log|e| / de2 = (I - 2 e e^T / |e|^2) / |e|^2.
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const Eigen::Vector3d m = e1.cross(e2);
  const double mm = m.squaredNorm(), aa = e1.squaredNorm(), bb = e2.squaredNorm();
  if (!(aa > 1e-300) || !(bb > 1e-300) || !(mm > 1e-300 * aa * bb)) return false;
  const double sine = std::sqrt(mm / (aa * bb));
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d g = m / mm;
  const Eigen::Matrix3d h_m = (identity - 2.0 * m * m.transpose() / mm) / mm;
  const Eigen::Matrix3d j1 = -Skew(e2), j2 = Skew(e1);
  Eigen::Matrix<double, 6, 1> grad_phi;
  grad_phi << j1.transpose() * g - e1 / aa, j2.transpose() * g - e2 / bb;
  Eigen::Matrix<double, 6, 6> h;
  h.block<3, 3>(0, 0) = j1.transpose() * h_m * j1 - (identity - 2.0 * e1 * e1.transpose() / aa) / aa;
  h.block<3, 3>(3, 3) = j2.transpose() * h_m * j2 - (identity - 2.0 * e2 * e2.transpose() / bb) / bb;
  h.block<3, 3>(0, 3) = j1.transpose() * h_m * j2 - Skew(g);
  h.block<3, 3>(3, 0) = h.block<3, 3>(0, 3).transpose();
  h = sine * (h + grad_phi * grad_phi.transpose());
  Eigen::Matrix<double, 2, 4> coefficients;
  coefficients << -1, 1, 0, 0,  //
                  0, 0, -1, 1;
  ToPoints<2>(coefficients, h, hessian);
  return true;
}

bool SelfContactDistanceHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                Eigen::Matrix<double, 12, 12>* hessian) {
  // (u, v, w) = L (p0, p1, p2, p3), L made of +-I blocks: coefficient of point j in each.
  const Eigen::Vector3d& p0 = points[0];
  const Eigen::Vector3d& p1 = points[1];
  const Eigen::Vector3d& p2 = points[2];
  const Eigen::Vector3d& p3 = points[3];
  Eigen::Matrix<double, 3, 4> coefficients;
  Eigen::Matrix<double, 9, 9> h;  // with respect to (u, v, w)
  if (pair.kind == SelfContactPair::Kind::kPointTriangle) {
    // u = P1 - P0, v = P2 - P0, w = p - P0 (points: p, P0, P1, P2).
    coefficients << 0, -1, 1, 0,  //
                    0, -1, 0, 1,  //
                    1, -1, 0, 0;
    if (!UnitCrossDotHessian(p2 - p1, p3 - p1, p0 - p1, &h)) return false;
  } else {
    // u = pb - pa, v = qb - qa, w = pa - qa (points: pa, pb, qa, qb).
    coefficients << -1, 1, 0, 0,  //
                    0, 0, -1, 1,  //
                    1, 0, -1, 0;
    if (!UnitCrossDotHessian(p1 - p0, p3 - p2, p0 - p2, &h)) return false;
    h *= pair.sign;
  }
  ToPoints<3>(coefficients, h, hessian);
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

void ObstacleContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                       const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                                       std::vector<double>* values) const {
  // The Gauss-Newton part (positive semi-definite) for both kinds.
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    if (!(Distance(s.Position(x), &g) < thickness_)) continue;
    const Eigen::Matrix3d h = stiffness_[i] * g * g.transpose();
    std::vector<int> vertices(s.vertex, s.vertex + 4);
    Eigen::MatrixXd hessian(12, 12);
    for (int j = 0; j < 4; ++j) {
      for (int l = 0; l < 4; ++l) hessian.block<3, 3>(3 * j, 3 * l) = s.weight[j] * s.weight[l] * h;
    }
    AddVertexHessian(vertices, hessian, pattern, values);
  }
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

// Calls visit(pair, stencils, points, r, dr) for every pair of `pairs` active at positions
// x (3 x num_vertices): its stencils and points (point, then corners), its residual r != 0
// and r's gradient dr with respect to the four points (3 x 4).
template <typename Visit>
void ForEachActivePair(const std::vector<SelfContactPair>& pairs,
                       const Eigen::Ref<const Eigen::Matrix3Xd>& x, double thickness,
                       double max_depth, double margin, const Visit& visit) {
  for (const SelfContactPair& pair : pairs) {
    const PointStencil* stencils[4] = {&pair.point, &pair.corner[0], &pair.corner[1],
                                       &pair.corner[2]};
    Eigen::Vector3d points[4];
    for (int m = 0; m < 4; ++m) points[m] = stencils[m]->Position(x);
    Eigen::Matrix<double, 3, 4> dr;
    const double r = PairResidual(pair, points, thickness, max_depth, margin, &dr);
    if (r != 0.0) visit(pair, stencils, points, r, dr);
  }
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
  ForEachActivePair(pairs_, x, thickness_, max_depth_, margin_,
                    [&](const SelfContactPair&, const PointStencil* const* stencils,
                        const Eigen::Vector3d*, double r, const Eigen::Matrix<double, 3, 4>& dr) {
    energy += 0.5 * r * r;
    for (int m = 0; m < 4; ++m) {
      for (int j = 0; j < 4; ++j) gradient->col(stencils[m]->vertex[j]) += r * stencils[m]->weight[j] * dr.col(m);
    }
  });
  return energy;
}

void SelfContactTerm::AppendVertexCouplings(std::vector<std::vector<int>>* couplings) const {
  for (const SelfContactPair& pair : pairs_) couplings->push_back(BlocksOf(pair).vertices);
}

void SelfContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                   const StiffnessPattern& pattern, StiffnessKind kind,
                                   std::vector<double>* values) const {
  ForEachActivePair(pairs_, x, thickness_, max_depth_, margin_,
                    [&](const SelfContactPair& pair, const PointStencil* const* stencils,
                        const Eigen::Vector3d* points, double r,
                        const Eigen::Matrix<double, 3, 4>& dr) {
    // Hessian of r^2 / 2 at the points: dr dr^T + r d2r, with d2r = -sqrt(k) Hess s, or
    // for edge-edge pairs in the fade band (r = w(x) q, q = sqrt(k) (thickness + offset -
    // s), x = (sine - kEdgeFadeSine) / band):
    //   d2r = w d2q + q d2w + dw dq^T + dq dw^T,
    //   d2w = w''(x) / band^2 dsine dsine^T + w'(x) / band Hess sine.
    const Eigen::Map<const Eigen::Matrix<double, 12, 1>> dr_flat(dr.data());
    Eigen::Matrix<double, 12, 12> h_points = dr_flat * dr_flat.transpose();
    Eigen::Matrix<double, 12, 12> hess_s;
    double s = 0, outside = 0;
    Eigen::Matrix<double, 3, 4> ds;
    // kProjected: the Gauss-Newton part dr dr^T alone (positive semi-definite).
    if (kind == StiffnessKind::kExact && SelfContactDistanceHessian(pair, points, &hess_s) &&
        SelfContactDistance(pair, points, &s, &ds, &outside)) {
      const double root_k = std::sqrt(pair.stiffness);
      Eigen::Matrix<double, 12, 12> d2r = -root_k * hess_s;
      double sine = 0;
      Eigen::Matrix<double, 3, 4> dsine;
      Eigen::Matrix<double, 12, 12> hess_sine;
      if (pair.kind == SelfContactPair::Kind::kEdgeEdge &&
          EdgeSine(points[0], points[1], points[2], points[3], &sine, &dsine) &&
          sine < kFullEdgeSine && EdgeSineHessian(points[0], points[1], points[2], points[3], &hess_sine)) {
        const double band = kFullEdgeSine - kEdgeFadeSine;
        const double t = (sine - kEdgeFadeSine) / band;  // in (0, 1): r != 0
        const double root = std::sqrt(3.0 - 2.0 * t);
        const double w = t * root, dw = root - t / root;
        const double d2w = -2.0 / root - t / (root * root * root);
        const double q = root_k * (thickness_ + pair.offset - s);
        const Eigen::Map<const Eigen::Matrix<double, 12, 1>> ds_flat(ds.data()), dsine_flat(dsine.data());
        const Eigen::Matrix<double, 12, 1> dq = -root_k * ds_flat;
        const Eigen::Matrix<double, 12, 1> dw_flat = dw / band * dsine_flat;
        const Eigen::Matrix<double, 12, 12> hess_w =
            d2w / (band * band) * dsine_flat * dsine_flat.transpose() + dw / band * hess_sine;
        d2r = w * d2r + q * hess_w + dw_flat * dq.transpose() + dq * dw_flat.transpose();
      }
      h_points += r * d2r;
    }
    // Chained to the stencils' simulation vertices.
    const PairBlocks blocks = BlocksOf(pair);
    const int n = static_cast<int>(blocks.vertices.size());
    Eigen::MatrixXd hessian = Eigen::MatrixXd::Zero(3 * n, 3 * n);
    for (int m = 0; m < 4; ++m) {
      for (int j = 0; j < 4; ++j) {
        for (int m2 = 0; m2 < 4; ++m2) {
          for (int j2 = 0; j2 < 4; ++j2) {
            hessian.block<3, 3>(3 * blocks.slot[4 * m + j], 3 * blocks.slot[4 * m2 + j2]) +=
                stencils[m]->weight[j] * stencils[m2]->weight[j2] *
                h_points.block<3, 3>(3 * m, 3 * m2);
          }
        }
      }
    }
    AddVertexHessian(blocks.vertices, hessian, pattern, values);
  });
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
