// Linear PCA of surfaces and its ridge-regularized marker fits (eval/surface_pca.h), the
// baselines of the evaluation and of aqs_bench_fit.

#include "eval/surface_pca.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

constexpr int kVertices = 30;

// `count` surfaces mean + sum_j c_j mode_j of `modes` fixed random modes, the
// coefficients random (seed).
std::vector<Eigen::Matrix3Xd> LinearSurfaces(int count, int modes, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random = [&](int rows, int cols) {
    Eigen::MatrixXd m(rows, cols);
    for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(rng);
    return m;
  };
  const Eigen::MatrixXd mean = random(3, kVertices);
  std::vector<Eigen::MatrixXd> basis;
  for (int j = 0; j < modes; ++j) basis.push_back(random(3, kVertices));
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (int p = 0; p < count; ++p) {
    Eigen::Matrix3Xd s = mean;
    for (int j = 0; j < modes; ++j) s += normal(rng) * basis[j];
    surfaces.push_back(s);
  }
  return surfaces;
}

TEST(SurfacePcaTest, ReproducesSurfacesInItsSpan) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(6, 2, 1);
  const SurfacePca pca(surfaces, 2);
  EXPECT_EQ(pca.num_components(), 2);
  for (const Eigen::Matrix3Xd& s : surfaces) {
    EXPECT_LT((pca.Decode(pca.Encode(s)) - s).cwiseAbs().maxCoeff(), 1e-10);
    const std::vector<int> markers = {0, 5, 9};
    Eigen::Matrix3Xd at(3, 3);
    for (int i = 0; i < 3; ++i) at.col(i) = s.col(markers[i]);
    EXPECT_LT((pca.FitToVertices(markers, at) - s).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((pca.FitToVerticesRidge(markers, at, 0.0) - s).cwiseAbs().maxCoeff(), 1e-9);
  }
}

// Markers that determine the coefficients: no ridge reproduces a left-out surface
// exactly, and a large one pulls it to the mean; ridge 0 wins.
TEST(SurfacePcaTest, LeaveOneOutPrefersNoRidgeWhereMarkersDetermineTheFit) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(8, 2, 2);
  const RidgeChoice choice = ChooseRidgeLeaveOneOut(surfaces, 2, {1, 7, 12, 20}, {}, {1e6, 0.0});
  EXPECT_EQ(choice.ridge, 0.0);
  EXPECT_LT(choice.loo_error, 1e-9);
  ASSERT_EQ(choice.errors.size(), 2u);
  EXPECT_GT(choice.errors[0], 0.1);
  EXPECT_EQ(choice.loo_error, choice.errors[1]);
}

// One marker (3 numbers) for 5 coefficients: unregularized least squares is
// underdetermined and errs; a ridge (the training spread as a prior) does better.
TEST(SurfacePcaTest, LeaveOneOutChoosesARidgeWhereMarkersAreFew) {
  const std::vector<Eigen::Matrix3Xd> surfaces = LinearSurfaces(12, 5, 3);
  const RidgeChoice choice =
      ChooseRidgeLeaveOneOut(surfaces, 5, {4}, {}, {0.0, 0.01, 0.1, 1.0, 10.0});
  EXPECT_GT(choice.ridge, 0.0);
  EXPECT_LT(choice.loo_error, choice.errors[0]);
  // Ties go to the first candidate.
  const RidgeChoice tie = ChooseRidgeLeaveOneOut(surfaces, 5, {4}, {}, {0.1, 0.1});
  EXPECT_EQ(tie.errors[0], tie.errors[1]);
  EXPECT_EQ(tie.ridge, 0.1);
}

}  // namespace
}  // namespace aqs
