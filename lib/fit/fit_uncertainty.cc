// LatentFitter::EstimateUncertainty: the Gaussian posterior of a solved fit
// (LatentFitOptions::uncertainty).

#include <cmath>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/covariance.h>
#include <ceres/problem.h>
#include <glog/logging.h>

#include "fit/fit_cost.h"
#include "fit/fit_equilibrium.h"
#include "fit/latent_fit.h"

namespace aqs {

void LatentFitter::EstimateUncertainty(ceres::Problem* problem, const std::vector<double*>& blocks,
                                       ceres::ResidualBlockId data_block,
                                       const FitCost* data_cost, double data_weight,
                                       FitEquilibrium* equilibrium, LatentFitResult* result) {
  std::vector<int> sizes;
  for (double* block : blocks) sizes.push_back(problem->ParameterBlockSize(block));
  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t i = 0; i < blocks.size(); ++i) {
    for (size_t j = i; j < blocks.size(); ++j) pairs.emplace_back(blocks[i], blocks[j]);
  }
  // (J^T J)^-1 of the cost at the result (a pseudo-inverse without the directions the
  // data and priors leave flat). Evaluating J prepares the point's derivatives.
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = -1;
  covariance_options.num_threads = options_.num_threads;
  ceres::Covariance covariance(covariance_options);
  if (!covariance.Compute(pairs, problem)) {
    result->uncertainty_message = "the covariance of the fitted parameters could not be computed";
    return;
  }
  int total = 0;
  std::vector<int> offsets;
  for (int size : sizes) {
    offsets.push_back(total);
    total += size;
  }
  Eigen::MatrixXd inverse(total, total);
  for (size_t i = 0; i < blocks.size(); ++i) {
    for (size_t j = i; j < blocks.size(); ++j) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block(sizes[i],
                                                                                   sizes[j]);
      covariance.GetCovarianceBlock(blocks[i], blocks[j], block.data());
      inverse.block(offsets[i], offsets[j], sizes[i], sizes[j]) = block;
      inverse.block(offsets[j], offsets[i], sizes[j], sizes[i]) = block.transpose();
    }
  }
  // The noise: the data's used residuals have cost (1/2) sum r^2 over N of them; with P
  // parameters their per-residual variance is 2 cost / (N - P). The parameters'
  // posterior covariance under that noise is this variance times (J^T J)^-1. (A scan
  // point beyond max_distance has a constant residual and no Jacobian row: the fit
  // ignores it, and so does the noise.)
  std::vector<double> values(data_cost->num_residuals());
  double cost = 0.0;
  if (!problem->EvaluateResidualBlock(data_block, true, &cost, values.data(), nullptr)) {
    result->uncertainty_message = "the data residuals could not be evaluated at the result";
    return;
  }
  double used_cost = 0.0;
  const int residuals = data_cost->UsedResiduals(values.data(), &used_cost);
  if (residuals <= total) {
    result->uncertainty_message = "fewer data residuals (" + std::to_string(residuals) +
                                  ") than parameters (" + std::to_string(total) + ")";
    return;
  }
  const double variance = 2.0 * used_cost / (residuals - total);
  result->parameter_covariance = variance * inverse;
  // The residuals are scaled by sqrt(w_k / W) (FitCost); sigma in model units is the
  // unscaled residuals' standard deviation.
  result->noise_sigma = std::sqrt(variance * data_weight);
  // dx*/dparameters at the result (the covariance's Jacobian prepared it).
  const FitEquilibrium::Point* point = equilibrium->Prepare(blocks.data(), true);
  if (point == nullptr) {
    result->parameter_covariance.resize(0, 0);
    result->uncertainty_message = "the equilibrium's derivatives could not be prepared";
    return;
  }
  const Eigen::Index rows = 3 * static_cast<Eigen::Index>(point->state.cols());
  Eigen::MatrixXd dx(rows, total);
  dx.leftCols(sizes[0]) = equilibrium->LatentProduct();
  for (size_t b = 1; b < blocks.size(); ++b) {
    dx.middleCols(offsets[b], 6) = equilibrium->BoneProduct(b - 1);
  }
  const int ns = model_.num_surface_vertices();
  result->surface_std.resize(ns);
  for (int v = 0; v < ns; ++v) {
    const PointStencil stencil = EmbeddingStencil(model_.embedding, model_.mesh.tets, v);
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(3, total);
    for (int j = 0; j < 4; ++j) {
      g += stencil.weight[j] * dx.middleRows(3 * static_cast<Eigen::Index>(stencil.vertex[j]), 3);
    }
    result->surface_std[v] =
        std::sqrt(std::max(0.0, (g * result->parameter_covariance * g.transpose()).trace()));
  }
}

}  // namespace aqs
