#include "contact/self_contact_term.h"

#include <algorithm>
#include <cmath>

#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <glog/logging.h>

namespace aqs {

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
  // The fade weight w = sqrt(smoothstep(x)) = x sqrt(3 - 2 x) of the fade variable's
  // position x in its band (dw/dx = 0 at x = 1; w^2 is C1 at x = 0).
  double f = 0;
  Eigen::Matrix<double, 3, 4> df;
  if (!SelfContactFadeVariable(pair, points, &f, &df)) return 0.0;
  const SelfContactFadeBand band = FadeBandOf(pair);
  const double x = (f - band.zero) / (band.full - band.zero);
  if (!(x > 0.0)) return 0.0;
  const double scale = std::sqrt(pair.stiffness);
  const double r = scale * (thickness - s);
  if (x >= 1.0) {
    *gradient = -scale * ds;
    return r;
  }
  const double root = std::sqrt(3.0 - 2.0 * x);
  const double w = x * root, dw_dx = root - x / root;
  *gradient = -scale * w * ds + r * dw_dx / (band.full - band.zero) * df;
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
    // in the fade band (r = w(x) q, q = sqrt(k) (thickness + offset - s),
    // x = (f - band.zero) / width with f the fade variable):
    //   d2r = w d2q + q d2w + dw dq^T + dq dw^T,
    //   d2w = w''(x) / width^2 df df^T + w'(x) / width Hess f.
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
      const SelfContactFadeBand band = FadeBandOf(pair);
      double f = 0;
      Eigen::Matrix<double, 3, 4> df;
      Eigen::Matrix<double, 12, 12> hess_f;
      if (SelfContactFadeVariable(pair, points, &f, &df) && f < band.full &&
          SelfContactFadeVariableHessian(pair, points, &hess_f)) {
        const double width = band.full - band.zero;
        const double t = (f - band.zero) / width;  // in (0, 1): r != 0
        const double root = std::sqrt(3.0 - 2.0 * t);
        const double w = t * root, dw = root - t / root;
        const double d2w = -2.0 / root - t / (root * root * root);
        const double q = root_k * (thickness_ + pair.offset - s);
        const Eigen::Map<const Eigen::Matrix<double, 12, 1>> ds_flat(ds.data()), df_flat(df.data());
        const Eigen::Matrix<double, 12, 1> dq = -root_k * ds_flat;
        const Eigen::Matrix<double, 12, 1> dw_flat = dw / width * df_flat;
        const Eigen::Matrix<double, 12, 12> hess_w =
            d2w / (width * width) * df_flat * df_flat.transpose() + dw / width * hess_f;
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
