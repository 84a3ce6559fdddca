#include "physics/shape_target_model.h"

#include <cmath>

#include <glog/logging.h>

#include "util/parallel_for.h"

namespace aqs {

ShapeTargetModel::ShapeTargetModel(const TetMesh& mesh, double mu)
    : ShapeTargetModel(mesh, Eigen::VectorXd::Constant(mesh.num_tets(), mu)) {}

ShapeTargetModel::ShapeTargetModel(const TetMesh& mesh, const Eigen::VectorXd& mu)
    : num_vertices_(mesh.num_vertices()),
      tets_(mesh.tets),
      rest_positions_(mesh.vertices),
      mu_(mu) {
  CHECK_EQ(mu.size(), mesh.num_tets()) << "one mu per element";
  CHECK_GT(mesh.num_tets(), 0);
  rest_shapes_.resize(mesh.num_tets());
  weights_.resize(mesh.num_tets());
  double scale_sum = 0.0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) {
      CHECK(tets_(k, e) >= 0 && tets_(k, e) < num_vertices_) << "element " << e;
    }
    CHECK(mu_[e] > 0.0 && std::isfinite(mu_[e])) << "mu of element " << e << " = " << mu_[e];
    rest_shapes_[e] = ComputeElementRestShape(
        mesh.vertices.col(tets_(0, e)), mesh.vertices.col(tets_(1, e)),
        mesh.vertices.col(tets_(2, e)), mesh.vertices.col(tets_(3, e)));
    weights_[e] = GradientWeights(rest_shapes_[e].dm_inverse);
    total_volume_ += rest_shapes_[e].volume;
    stiffness_volume_ += mu_[e] * rest_shapes_[e].volume;
    scale_sum += mu_[e] * std::cbrt(rest_shapes_[e].volume * rest_shapes_[e].volume);
  }
  force_scale_ = 2.0 * scale_sum / mesh.num_tets();
}

Eigen::Matrix3d ShapeTargetModel::DeformationGradient(const PositionsRef& x, int e) const {
  return aqs::DeformationGradient(weights_[e], x.col(tets_(0, e)).data(),
                                  x.col(tets_(1, e)).data(), x.col(tets_(2, e)).data(),
                                  x.col(tets_(3, e)).data());
}

ShapeTargetElement ShapeTargetModel::Element(const PositionsRef& x, const ActuationRef& a,
                                             int e, const PolarCache* cache) const {
  if (cache != nullptr) {
    return ShapeTargetElement(DeformationGradient(x, e), SymmetricFromActuation(a.col(e).data()),
                              mu_[e], cache->svd(e));
  }
  return ShapeTargetElement(DeformationGradient(x, e), SymmetricFromActuation(a.col(e).data()),
                            mu_[e]);
}

double ShapeTargetModel::Energy(const PositionsRef& x, const ActuationRef& a,
                                int num_threads) const {
  CHECK_EQ(x.cols(), num_vertices_);
  CHECK_EQ(a.cols(), num_elements());
  const int threads = ParallelForThreadCount(num_threads, num_elements());
  std::vector<double> partial(threads, 0.0);
  ParallelForFixedOrder(threads, 0, num_elements(), [&](int t, int e) {
    partial[t] += rest_shapes_[e].volume * Element(x, a, e).EnergyDensity();
  });
  double total = 0.0;
  for (double p : partial) total += p;
  return total;
}

double ShapeTargetModel::EnergyAndGradient(const PositionsRef& x, const ActuationRef& a,
                                           Eigen::Matrix3Xd* gradient, int num_threads,
                                           PolarCache* cache) const {
  CHECK_EQ(x.cols(), num_vertices_);
  CHECK_EQ(a.cols(), num_elements());
  const int threads = ParallelForThreadCount(num_threads, num_elements());
  std::vector<Eigen::Matrix3Xd> partial(threads, Eigen::Matrix3Xd::Zero(3, num_vertices_));
  std::vector<double> energy(threads, 0.0);
  const PolarCache* known = PolarCache::IfMatches(cache, x, a);
  PolarCache* fill = cache != nullptr && known == nullptr ? cache : nullptr;
  if (fill != nullptr) fill->Begin(x, a, num_elements());
  ParallelForFixedOrder(threads, 0, num_elements(), [&](int t, int e) {
    const ShapeTargetElement element = Element(x, a, e, known);
    if (fill != nullptr) fill->Store(e, element.svd());
    const double volume = rest_shapes_[e].volume;
    energy[t] += volume * element.EnergyDensity();
    const Eigen::Matrix<double, 3, 4> nodal = volume * element.Stress() * weights_[e];
    for (int k = 0; k < 4; ++k) partial[t].col(tets_(k, e)) += nodal.col(k);
  });
  if (fill != nullptr) fill->Finish();
  *gradient = partial[0];
  double total = energy[0];
  for (int t = 1; t < threads; ++t) {
    *gradient += partial[t];
    total += energy[t];
  }
  return total;
}

double ShapeTargetModel::EnergyActuationGradient(const PositionsRef& x, const ActuationRef& a,
                                                 ActuationMatrix* gradient, int num_threads,
                                                 const PolarCache* cache) const {
  CHECK_EQ(x.cols(), num_vertices_);
  CHECK_EQ(a.cols(), num_elements());
  gradient->resize(6, num_elements());
  const int threads = ParallelForThreadCount(num_threads, num_elements());
  std::vector<double> partial(threads, 0.0);
  const PolarCache* known = PolarCache::IfMatches(cache, x, a);
  ParallelForFixedOrder(threads, 0, num_elements(), [&](int t, int e) {
    const ShapeTargetElement element = Element(x, a, e, known);
    const double volume = rest_shapes_[e].volume;
    partial[t] += volume * element.EnergyDensity();
    gradient->col(e) = volume * element.EnergyActuationGradient();
  });
  double total = 0.0;
  for (double p : partial) total += p;
  return total;
}

}  // namespace aqs
